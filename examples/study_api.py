"""Run fuzzy studies of the closed-form demo models from Python.

python examples/study_api.py            # writes into ./study-api-out/
"""

from pathlib import Path

import fuzzymbs
from fuzzymbs import Triangular

out = Path("study-api-out")

# 1. z = x1 * x2: the reduced method is exact for this monotonic model.
product = fuzzymbs.Study(
    "product",
    {"x1": Triangular(1.0, 2.0, 3.0), "x2": Triangular.relative(10.0, 0.1)},
    method="reduced",
    levels=4,
)
result = product.run(progress=False)
print(result.summary())
print("support of z:", result.alpha_cut("z", 0.0))
print("relative influence:", result.dataset["z_relative_influence"].values)

# 2. A fuzzy time signal: free vibration of a damped oscillator. Parameters left out
#    (damping) keep their defaults; a plain number would fix them at another value.
oscillator = fuzzymbs.Study(
    "damped-oscillator",
    {
        "mass": {"type": "triangular", "modal": 1.0, "spread": 0.05},  # kg
        "stiffness": Triangular.relative(1000.0, 0.1),  # N/m
    },
    method="extended",
    levels=4,
    nonmonotonic=["mass", "stiffness"],
    model_options={"duration": 0.5, "time_steps": 201},
    name="oscillator",
)
# A store makes the run resumable: rerunning this script evaluates nothing again.
result = oscillator.run(store=out / "oscillator-chunks", chunk_size=16, progress=True)
result.to_netcdf(out / "oscillator.nc")
for path in result.plot(out, formats=("png",)):
    print("wrote", path)
