"""Rounds of the adaptive method padded to whole SIMD blocks, against today's rounds.

    python benchmarks/round_padding.py [--study 1] [--multiples 1 4 8] [--file STUDY.toml]

A brake run costs about as much in a block of four samples as alone (a block of one
takes about 0.8 of a full block's CPU, docs/benchmarks.md "Lane width"), so a round of
13 runs leaves three lanes of its last block nearly free. This experiment fills them:
each refinement round (not the first, not the extremum confirmation) is padded to a
multiple of ``M`` points with the next most doubtful extremal points far from every run
(the method's own certification points, :meth:`AdaptiveTransformation._certification_points`,
taken again with the round's points as planned). It patches the method in a child
process that runs ``fuzzymbs run`` of the demo's study (or ``--file``, any adaptive study)
without plots; M = 1 is today's method. Prints one JSON line: per multiple, wall and CPU
of the child, runs, rounds, the size of each round and the certified method and
time-integration errors (:func:`brake_targets.run_file`'s figures).

The padding is not part of fuzzymbs: on the brake's study 1 it added runs without
saving a round (docs/benchmarks.md, "The runs that judge a brake study").
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

from bench_common import REPO, load_average
from brake_targets import run_file

DEMOS = REPO / "src" / "fuzzymbs" / "demos" / "brake"
FILES = {1: DEMOS / "01-study1.toml", 2: DEMOS / "02-study2.toml"}

_CHILD = """
import atexit
import json
import sys
from pathlib import Path

import numpy as np
from fuzzymbs.fuzzy import adaptive

# sys.argv: the multiple, then the command line of ``fuzzymbs``
multiple, arguments = int(sys.argv[1]), sys.argv[2:]
out = Path(arguments[arguments.index("--out") + 1])
plan_round = adaptive.AdaptiveTransformation._plan_round
doubt_of = adaptive.AdaptiveTransformation._doubt


def remember(self, scale, correction):
    # the round's doubt, taken before its refinement adds grid indices without values
    self._round_doubt = doubt_of(self, scale, correction)
    return self._round_doubt


def padded(self):
    points, labels = plan_round(self)
    count = len(points)
    if multiple > 1 and count % multiple and self.rounds > 0 and not self.confirming:
        need = multiple - count % multiple
        units = self.to_unit(points)
        extra = self._certification_points(units, need, self._round_doubt)[:need]
        points = np.concatenate((points, self.to_parameters(extra)))
        labels = [*labels, *([None] * len(extra))]
    return points, labels


sizes = []
add = adaptive.AdaptiveTransformation.add


def counted(self, points, *args, **kwargs):
    sizes.append(len(points))
    return add(self, points, *args, **kwargs)


adaptive.AdaptiveTransformation._doubt = remember
adaptive.AdaptiveTransformation._plan_round = padded
adaptive.AdaptiveTransformation.add = counted
atexit.register(lambda: (out / "rounds.json").write_text(json.dumps(sizes)))
from fuzzymbs.cli import main

sys.argv = ["fuzzymbs", *arguments]
main()
"""


def run_padded(multiple: int, path: Path, out: Path) -> dict[str, Any]:
    """The study of ``path`` with its rounds padded to ``multiple``, in a child process
    (:func:`brake_targets.run_file` with the patched method as its program)."""
    program = (sys.executable, "-c", _CHILD, str(multiple))
    figures = run_file(path, out, ("--no-plots",), program=program)
    return {
        "multiple": multiple,
        **figures,
        "round_sizes": json.loads((out / "rounds.json").read_text()),
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=int, default=1, choices=sorted(FILES))
    parser.add_argument("--multiples", type=int, nargs="+", default=[1, 4, 8])
    parser.add_argument("--file", type=Path, help="an adaptive study file instead of --study")
    args = parser.parse_args(argv)
    path = args.file or FILES[args.study]
    figures: dict[str, Any] = {"study": str(path), "load_average_start": load_average()}
    with tempfile.TemporaryDirectory() as folder:
        figures["runs"] = [run_padded(m, path, Path(folder) / f"pad{m}") for m in args.multiples]
    figures["load_average_end"] = load_average()
    return figures


if __name__ == "__main__":
    print(json.dumps(main()))
