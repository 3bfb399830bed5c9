#!/usr/bin/env python3
"""A stand-in for an external simulator that reads an input deck and writes a CSV file.

    oscillator_solver.py DECK RESULT

DECK holds ``name = value`` lines (``#`` starts a comment): mass ``m`` [kg], damping
``c`` [N s/m], stiffness ``k`` [N/m], initial displacement ``x0`` [m], and the time grid
``duration`` [s] and ``points``. RESULT gets the free response of the damped oscillator
m x'' + c x' + k x = 0, x(0) = x0, x'(0) = 0 (closed form, underdamped) as columns
``time,x,v`` with full precision. Invalid values end the program with exit status 2 and a
message on stderr, as a real solver would.
"""

import math
import sys


def read_deck(path):
    values = {}
    with open(path, encoding="utf-8") as handle:
        for number, line in enumerate(handle, start=1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            name, sep, value = line.partition("=")
            if not sep:
                sys.exit(f"{path}:{number}: expected 'name = value', got {line!r}")
            values[name.strip()] = float(value)
    return values


def main(deck, result):
    values = read_deck(deck)
    m, c, k = values.get("m", 1.0), values["c"], values["k"]
    x0, duration, points = values.get("x0", 0.01), values["duration"], int(values["points"])
    if not (m > 0 and k > 0 and c >= 0):
        print(f"error: need m > 0, k > 0, c >= 0 (m = {m}, k = {k}, c = {c})", file=sys.stderr)
        return 2
    sigma = c / (2.0 * m)
    if sigma * sigma >= k / m:
        print(f"error: c = {c} is not below critical damping", file=sys.stderr)
        return 2
    wd = math.sqrt(k / m - sigma * sigma)
    with open(result, "w", encoding="utf-8") as out:
        out.write("time,x,v\n")
        for i in range(points):
            t = duration * i / (points - 1)
            decay = math.exp(-sigma * t)
            x = decay * x0 * (math.cos(wd * t) + sigma / wd * math.sin(wd * t))
            v = -decay * x0 * (sigma * sigma / wd + wd) * math.sin(wd * t)
            out.write(f"{t!r},{x!r},{v!r}\n")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
