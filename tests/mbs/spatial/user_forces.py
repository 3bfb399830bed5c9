"""User force elements for the spatial tests (compiled once, cached, like a user's module)."""

import math

from fuzzymbs.mbs.spatial import user_force


@user_force
def line_spring(element, t, marker_i, marker_j, parameters, out):  # pragma: no cover - compiled
    # a linear spring between the markers' points: stiffness parameters[0], free length
    # parameters[1]; the force on marker i pulls it towards marker j
    dx = marker_j[0] - marker_i[0]
    dy = marker_j[1] - marker_i[1]
    dz = marker_j[2] - marker_i[2]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    tension = parameters[0] * (length - parameters[1])
    out[0] = tension * dx / length
    out[1] = tension * dy / length
    out[2] = tension * dz / length
    out[3] = 0.0
    out[4] = 0.0
    out[5] = 0.0
