"""Where the brake kernel's time goes: the same batch with parts of the model removed.

The compiled kernel cannot be instrumented from outside without slowing it, so
the cost is split by difference, each variant integrated for the same batch
and steps:

* ``full``: the brake as the study runs it (two-pass contact, 146 slave nodes);
* ``single_pass``: pad nodes against the disc only (50 slave nodes);
* ``no_contact``: no contact elements (the kernel then skips the node
  kinematics and force mapping as well): springs, nodal forces, modal and
  rotating-body equations and the RK4 updates only.

``full - no_contact`` is the contact path (node kinematics, contact search and
laws, force mapping); ``full - single_pass`` is the cost of the 96 extra slave
nodes of the second pass. Each variant's flop count (:mod:`brake_flops`) gives
its attained rate.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from bench_common import best_time, log


def _variant(contact: str | None, steps: int) -> Any:
    from brake_bench import DT, OUTPUTS

    from fuzzymbs.mbs.contact import PenaltyContact
    from fuzzymbs.mbs.integrate import SimulationModel
    from fuzzymbs.mbs.system import Coordinate
    from fuzzymbs.models.brake import BrakeDesign, brake_system, build_bodies

    system = brake_system(build_bodies(BrakeDesign()), contact or "two-pass")
    if contact is None:
        system.elements = [e for e in system.elements if not isinstance(e, PenaltyContact)]
    bodies = ("lower_pad", "upper_pad", "caliper")
    outputs = {name: Coordinate(body, 0) for name, body in zip(OUTPUTS, bodies, strict=True)}
    return SimulationModel(system, t_end=steps * DT, dt=DT, outputs=outputs, chunk_size=4096)


def profile(batch: int = 343, steps: int = 200, active_fraction: float = 0.95) -> dict[str, Any]:
    """Seconds per sample-step and GFLOP/s of each variant (see module docstring)."""
    from brake_flops import step_flops

    samples = {"nodal_force": np.full(batch, 16e3)}
    rows = {}
    for label, contact in (
        ("full", "two-pass"),
        ("single_pass", "single-pass"),
        ("no_contact", None),
    ):
        model = _variant(contact, steps)
        model(samples)
        seconds = best_time(lambda m=model: m(samples), repeat=2)
        per = seconds / (batch * steps)
        flops = step_flops(model.compiled.data, active_fraction)["flops_per_sample_step"]
        rows[label] = {"seconds_per_sample_step": per, "flops_per_sample_step": flops}
        rows[label]["gflops"] = flops / per / 1e9
        log(f"profile: {label}: {per * 1e6:.2f} us/sample-step, {flops / per / 1e9:.2f} GFLOP/s")
    full = rows["full"]["seconds_per_sample_step"]
    rows["share_contact_path"] = 1.0 - rows["no_contact"]["seconds_per_sample_step"] / full
    rows["share_second_pass"] = 1.0 - rows["single_pass"]["seconds_per_sample_step"] / full
    rows["batch"] = batch
    rows["steps"] = steps
    return rows


if __name__ == "__main__":
    import json

    print(json.dumps(profile(steps=50)))
