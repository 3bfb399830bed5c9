"""User force elements for the tests (compiled once, cached, like a user's own module)."""

from fuzzymbs.mbs.planar import user_force


@user_force
def linear_spring_x(element, t, marker_i, marker_j, parameters, out):  # pragma: no cover - compiled
    # a spring along x between the markers: the force on marker i is k (x_j - x_i - l0)
    out[0] = parameters[0] * (marker_j[0] - marker_i[0] - parameters[1])
    out[1] = 0.0
    out[2] = 0.0
