"""External simulators as fuzzymbs models.

- ``fmu``: a Functional Mock-up Unit (FMI 2.0 / 3.0, co-simulation or model
  exchange) through FMPy (:mod:`fuzzymbs.models.external.fmu`; optional
  extra ``fuzzymbs[fmu]``).
- ``command``: an external program run once per sample, with an input file
  from a template and a CSV output file (:mod:`fuzzymbs.models.external.command`).

Their parameters and outputs are those of the FMU or the program, known once
the model is built. A study file that names either runs code chosen by the
file's author, so it needs ``fuzzymbs run --allow-code`` (:mod:`fuzzymbs.study.trust`).
"""

from __future__ import annotations

from fuzzymbs.study.registry import register_model

register_model(
    "fmu",
    "fuzzymbs.models.external.fmu:make_fmu_model",
    parameters={},
    outputs={},
    description="a Functional Mock-up Unit (FMI 2.0/3.0, co-simulation or model exchange) "
    "via FMPy; parameters and outputs are its variables (fuzzymbs info FILE.fmu)",
    options={
        "path": ".fmu file (relative to the study file)",
        "stop_time": "end of the simulation [s]",
        "output_interval": "spacing of the recorded time grid [s]",
        "start_time": "start of the simulation [s] (default 0)",
        "step_size": "model exchange: fixed Euler step; co-simulation: communication step [s]",
        "solver_tolerance": "CVODE / co-simulation FMU relative tolerance (default 1e-6)",
        "interface": "auto | co-simulation | model-exchange (default auto)",
        "outputs": "FMU output variables to record (default all)",
    },
    dynamic=True,
    runs_code=True,
)

register_model(
    "command",
    "fuzzymbs.models.external.command:make_command_model",
    parameters={},
    outputs={},
    description="an external program run once per sample: {name} placeholders in an input "
    "template, a CSV file with a header row back",
    options={
        "command": 'program and arguments, e.g. ["solver", "{input}", "{output}"] (no shell)',
        "template": "input file template (relative to the study file); {name} = parameter",
        "timeout": "seconds a run may take (default: no limit)",
        "keep_runs": "keep run directories: true or a folder (default false)",
        "coordinate": "CSV column that is the coordinate of the others (default time)",
        "base_dir": "folder relative paths refer to (default: the study file's folder)",
    },
    dynamic=True,
    runs_code=True,
)
