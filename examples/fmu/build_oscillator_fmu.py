"""Build the example FMU: a damped oscillator for FMI 2.0 or 3.0 (model exchange and co-simulation).

The FMU is compiled from the C sources beside this script (``oscillator.h``,
``oscillator_fmi2.c``, ``oscillator_fmi3.c``) with the FMI headers that FMPy
ships and a C compiler (``$CC``, default ``cc``), for the platform it runs on::

    python examples/fmu/build_oscillator_fmu.py examples/fmu/oscillator.fmu          # FMI 2.0
    python examples/fmu/build_oscillator_fmu.py --fmi 3 examples/fmu/oscillator3.fmu

Parameters (settable reals): ``m`` [kg], ``c`` [N.s/m], ``k`` [N/m], ``x0`` [m], ``F`` [N];
an integer parameter ``order`` and a calculated parameter ``omega0`` [rad/s] (neither can be
fuzzy); outputs ``x`` [m] and ``v`` [m/s]. The tests build it too
(tests/models/test_fmu.py).
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: (name, value reference, causality, variability, start, unit, description) of the reals
REALS = (
    ("m", 0, "parameter", "fixed", 1.0, "kg", "mass"),
    ("c", 1, "parameter", "fixed", 0.4, "N.s/m", "viscous damping"),
    ("k", 2, "parameter", "fixed", 100.0, "N/m", "stiffness"),
    ("x0", 3, "parameter", "fixed", 0.01, "m", "initial displacement (released from rest)"),
    ("F", 4, "parameter", "fixed", 0.0, "N", "constant force"),
    ("omega0", 5, "calculatedParameter", "fixed", None, "rad/s", "undamped natural frequency"),
    ("x", 6, "output", "continuous", None, "m", "displacement"),
    ("v", 7, "output", "continuous", None, "m/s", "velocity"),
    ("der(x)", 8, "local", "continuous", None, "m/s", "derivative of x"),
    ("der(v)", 9, "local", "continuous", None, "m/s2", "derivative of v"),
)
ORDER_REFERENCE = 10
TIME_REFERENCE = 11  # FMI 3.0: the independent variable
UNITS = ("s", "kg", "N.s/m", "N/m", "m", "N", "rad/s", "m/s", "m/s2")
IDENTIFIER = "oscillator"


def _attributes(start: float | None, unit: str) -> str:
    text = f' unit="{unit}"'
    return text + (f' start="{start!r}"' if start is not None else "")


def _model_description_2(guid: str) -> str:
    index = {name: i + 1 for i, (name, *_rest) in enumerate(REALS)}
    variables = []
    for name, ref, causality, variability, start, unit, description in REALS:
        initial = ' initial="calculated"' if causality in ("calculatedParameter", "output") else ""
        derivative = f' derivative="{index[name[4:-1]]}"' if name.startswith("der(") else ""
        variables.append(
            f'    <ScalarVariable name="{name}" valueReference="{ref}" causality="{causality}" '
            f'variability="{variability}"{initial} description="{description}">'
            f"<Real{_attributes(start, unit)}{derivative}/></ScalarVariable>"
        )
    variables.append(
        f'    <ScalarVariable name="order" valueReference="{ORDER_REFERENCE}" '
        'causality="parameter" variability="fixed" description="an integer parameter">'
        '<Integer start="2"/></ScalarVariable>'
    )
    units = "".join(f'<Unit name="{u}"/>' for u in UNITS)
    initial = [index["omega0"], index["x"], index["v"], index["der(x)"], index["der(v)"]]
    derivatives = "".join(f'<Unknown index="{index[n]}"/>' for n in ("der(x)", "der(v)"))
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Oscillator" guid="{guid}"
  description="damped oscillator m x'' + c x' + k x = F (fuzzymbs example)"
  generationTool="fuzzymbs examples/fmu" numberOfEventIndicators="0">
  <ModelExchange modelIdentifier="{IDENTIFIER}"/>
  <CoSimulation modelIdentifier="{IDENTIFIER}" canHandleVariableCommunicationStepSize="true"/>
  <UnitDefinitions>{units}</UnitDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.01"/>
  <ModelVariables>
{chr(10).join(variables)}
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="{index["x"]}"/><Unknown index="{index["v"]}"/></Outputs>
    <Derivatives>{derivatives}</Derivatives>
    <InitialUnknowns>{"".join(f'<Unknown index="{i}"/>' for i in initial)}</InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def _model_description_3(token: str) -> str:
    references = {name: ref for name, ref, *_rest in REALS}
    variables = [
        f'    <Float64 name="time" valueReference="{TIME_REFERENCE}" causality="independent" '
        'variability="continuous" unit="s" description="time"/>'
    ]
    for name, ref, causality, variability, start, unit, description in REALS:
        initial = ' initial="calculated"' if causality in ("calculatedParameter", "output") else ""
        derivative = f' derivative="{references[name[4:-1]]}"' if name.startswith("der(") else ""
        variables.append(
            f'    <Float64 name="{name}" valueReference="{ref}" causality="{causality}" '
            f'variability="{variability}"{initial}{_attributes(start, unit)}{derivative} '
            f'description="{description}"/>'
        )
    variables.append(
        f'    <Int32 name="order" valueReference="{ORDER_REFERENCE}" causality="parameter" '
        'variability="fixed" start="2" description="an integer parameter"/>'
    )
    units = "".join(f'<Unit name="{u}"/>' for u in UNITS)
    initial = ["omega0", "x", "v", "der(x)", "der(v)"]
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Oscillator" instantiationToken="{token}"
  description="damped oscillator m x'' + c x' + k x = F (fuzzymbs example)"
  generationTool="fuzzymbs examples/fmu">
  <ModelExchange modelIdentifier="{IDENTIFIER}"/>
  <CoSimulation modelIdentifier="{IDENTIFIER}" canHandleVariableCommunicationStepSize="true"/>
  <UnitDefinitions>{units}</UnitDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.01"/>
  <ModelVariables>
{chr(10).join(variables)}
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="{references["x"]}"/>
    <Output valueReference="{references["v"]}"/>
    <ContinuousStateDerivative valueReference="{references["der(x)"]}"/>
    <ContinuousStateDerivative valueReference="{references["der(v)"]}"/>
{chr(10).join(f'    <InitialUnknown valueReference="{references[n]}"/>' for n in initial)}
  </ModelStructure>
</fmiModelDescription>
"""


def _platform_folder(fmi_version: int) -> str:
    machine = platform.machine().lower()
    system = {"linux": "linux", "darwin": "darwin", "windows": "win"}[platform.system().lower()]
    if fmi_version == 2:
        return f"{system}64" if machine in ("x86_64", "amd64", "arm64", "aarch64") else system
    architecture = {"amd64": "x86_64", "arm64": "aarch64"}.get(machine, machine)
    return f"{architecture}-{'windows' if system == 'win' else system}"


def build(out: str | Path, fmi_version: int = 2) -> Path:
    """Compile and zip the oscillator FMU for ``fmi_version`` (2 or 3) into ``out``.

    Raises
    ------
    RuntimeError
        No C compiler, or the compiler failed (its output in the message).
    """
    import fmpy

    if fmi_version not in (2, 3):
        raise ValueError(f"fmi_version must be 2 or 3, got {fmi_version!r}")
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        raise RuntimeError(f"no C compiler {compiler!r} on PATH (set CC) to build the example FMU")
    headers = Path(fmpy.__file__).parent / "c-code"
    suffix = {"Windows": ".dll", "Darwin": ".dylib"}.get(platform.system(), ".so")
    out = Path(out)
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        binaries = root / "binaries" / _platform_folder(fmi_version)
        binaries.mkdir(parents=True)
        command = [
            compiler,
            "-std=c99",
            "-O2",
            "-shared",
            "-fPIC",
            "-fvisibility=hidden" if fmi_version == 3 else "-fvisibility=default",
            f"-I{headers}",
            f"-I{HERE}",
            str(HERE / f"oscillator_fmi{fmi_version}.c"),
            "-o",
            str(binaries / f"{IDENTIFIER}{suffix}"),
            "-lm",
        ]
        compiled = subprocess.run(command, capture_output=True, text=True, check=False)
        if compiled.returncode != 0:
            raise RuntimeError(f"compiling the example FMU failed:\n{compiled.stderr}")
        identifier = (
            "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, f"fuzzymbs-oscillator-{fmi_version}")) + "}"
        )
        text = (_model_description_2 if fmi_version == 2 else _model_description_3)(identifier)
        (root / "modelDescription.xml").write_text(text, encoding="utf-8")
        sources = root / "sources"
        sources.mkdir()
        for name in ("oscillator.h", f"oscillator_fmi{fmi_version}.c"):
            shutil.copy(HERE / name, sources / name)
        out.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    archive.write(path, path.relative_to(root).as_posix())
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the .fmu file to write")
    parser.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version")
    arguments = parser.parse_args(argv)
    print(build(arguments.out, arguments.fmi))
    return 0


if __name__ == "__main__":
    sys.exit(main())
