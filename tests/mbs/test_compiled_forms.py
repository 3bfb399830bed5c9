"""Each kernel the brake and the gear dynamics call is compiled in one form only.

Numba compiles a jitted function once per distinct tuple of argument types, and a
literal argument (``0``, ``3``) is a type of its own: a callee passed a literal, or a
counter that starts as one (``rows = 0`` then ``rows += 3``, typed first as the
literal while Numba's type inference runs), is compiled again, and everything it
calls with it. The Jacobian's contact helpers were compiled five times each and the
right-hand side twice (RK4 passed one time for all lanes, the Rosenbrock methods a
time per lane): 13 s of the 102 s a fresh process took to compile the engine's kernels
(docs/contributing.md, "Which process compiles what"). Slow: in a fresh interpreter,
which loads the kernels from the cache the default suite wrote (or compiles them).
"""

from __future__ import annotations

import json

import pytest

pytestmark = pytest.mark.slow

_RUN_EVERY_PATH = """
import itertools, json
import numba
import numpy as np
from fuzzymbs.mbs.integrate import evaluate_rhs
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.models.gears import MubocoPR, make_pair

names = ("pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force")
modal = (200e3, 1e3, 16e3)
corners = np.array(list(itertools.product(*[(0.9 * m, 1.1 * m) for m in modal])))
samples = {name: corners[:, i] for i, name in enumerate(names)}
DiscBrake(t_end=2e-5, integrator="rk4")(samples)
DiscBrake(t_end=2e-5)(samples, wrt=list(names))
DiscBrake(t_end=2e-5, integrator="rodas4")(samples)
DiscBrake(t_end=2e-5).share_steps(dict(zip(names, modal)))(samples, wrt=list(names))
brake = DiscBrake(t_end=2e-5).compiled
params = brake.parameters.values({})
states = np.zeros((5, brake.n_state))
evaluate_rhs(brake, params, np.zeros(5, dtype=np.int64), np.arange(5) * 1e-5, states)
settings = {"speed_rpm": 300.0, "mesh_periods": 2, "output_periods": 1}
MubocoPR(make_pair(), torque=100.0, mode="dynamic", damping=3000.0, dynamic=settings)({})

import sys
twice = {}
for module_name, module in list(sys.modules.items()):
    if not module_name.startswith("fuzzymbs."):
        continue
    for name, value in vars(module).items():
        if isinstance(value, numba.core.registry.CPUDispatcher) and len(value.signatures) > 1:
            function = value.py_func  # once, not once per module that imports it
            twice[f"{function.__module__}.{function.__qualname__}"] = [
                str(s)[:300] for s in value.signatures
            ]
print(json.dumps(twice))
"""


def test_the_brakes_and_gears_kernels_compile_one_form_each(fresh_python):
    # 900 s: room to compile all these kernels (about 110 s on the AVX2 host), which a run
    # of the slow suite alone on a fresh clone has to
    twice = json.loads(fresh_python(_RUN_EVERY_PATH, timeout=900).splitlines()[-1])
    assert twice == {}, "compiled in more than one form:\n" + json.dumps(twice, indent=1)
