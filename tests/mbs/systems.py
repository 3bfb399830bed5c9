"""Small systems built from the engine's own bodies, springs and contact (shared by tests)."""

from __future__ import annotations

import numpy as np

from fuzzymbs.mbs.bodies import FixedBody, RotatingBody, TranslatingBody
from fuzzymbs.mbs.contact import CartesianChart, PenaltyContact, PolarChart
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.lumped import lumped_modal_body, rigid_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.system import System

# Hoffmann et al. (2002) minimal model, our parameter values (the paper's structure:
# a point mass on a moving belt, two springs at angles alpha_1, alpha_2, a contact spring k3).
HOFFMANN = {
    "mass": 1.0,  # kg
    "k1": 2.0e4,  # N/m at alpha1
    "alpha1": np.deg2rad(30.0),
    "k2": 1.0e4,  # N/m at alpha2
    "alpha2": np.deg2rad(150.0),
    "k3": 2.0e4,  # contact (penalty) stiffness, N/m
    "preload": 100.0,  # N pressing the mass on the belt
    # the belt is a disc face; a large radius makes its velocity direction at the mass
    # independent of the mass's tangential offset z to O((z / R)^2) ~ 1e-11
    "radius": 100.0,  # m, where the mass sits on the rotating "belt" disc
    "speed": 1e-3,  # rad/s -> belt speed 0.1 m/s
    "eps": 1e-7,  # m/s friction regularisation
}


def annulus_nodes(r_in: float, r_out: float, n_r: int, n_theta: int, y: float = 0.0):
    """Nodes of a full annulus in the plane y = const (polar grid, periodic in theta)."""
    r = np.linspace(r_in, r_out, n_r)
    th = np.linspace(0.0, 2 * np.pi, n_theta, endpoint=False)
    rr, tt = np.meshgrid(r, th, indexing="ij")
    return np.stack([rr * np.cos(tt), np.full(rr.shape, y), -rr * np.sin(tt)], -1).reshape(-1, 3)


def hoffmann_system(mu: float | Parameter = 0.0, damping: float = 0.0) -> System:
    """The 2-dof friction model from engine parts.

    The belt is the face y = 0 of a rigid disc rotating about y (a full annulus
    patch, so it never runs out); the mass sits on it at radius R, where the
    belt moves in -z at speed Omega R. The mass translates in z (tangential) and
    y (normal); springs k1, k2 act along (0, sin a, cos a) (y, z components).
    """
    h = HOFFMANN
    system = System()
    belt = rigid_body("belt", 1.0, annulus_nodes(0.8 * h["radius"], 1.2 * h["radius"], 3, 64))
    system.add_body(RotatingBody(belt, "y", speed=h["speed"]))
    block = rigid_body("block", h["mass"])
    system.add_body(TranslatingBody(block, ["z", "y"], origin=(h["radius"], 0.0, 0.0)))
    for name in ("1", "2"):
        a = h["alpha" + name]
        system.add(
            Spring(
                "k" + name,
                "block",
                [0],
                stiffness=h["k" + name],
                damping=damping,
                direction=(0.0, np.sin(a), np.cos(a)),
            )
        )
    system.add(NodalForce("preload", "block", [0], "y", -h["preload"]))
    system.add(
        PenaltyContact(
            "belt-contact",
            "block",
            [0],
            "belt",
            np.arange(belt.n_nodes),
            PolarChart("y", "x"),
            penalty=h["k3"],
            friction=mu,
            regularization_velocity=h["eps"],
            normal="y",
        )
    )
    return system


def hoffmann_matrices(mu: float, damping: float = 0.0):
    """Hand-written linear 2-dof reference (coordinates z, y about the sliding state).

    m z'' + k_zz z + (k_zy - mu k3) y = 0 (friction -mu N along the belt motion -z, N = -k3 y)
    m y'' + k_yz z + (k_yy + k3) y = 0
    """
    h = HOFFMANN
    stiff = np.zeros((2, 2))
    for name in ("1", "2"):
        a = h["alpha" + name]
        d = np.array([np.cos(a), np.sin(a)])
        stiff += h["k" + name] * np.outer(d, d)
    damp = np.zeros((2, 2))
    for name in ("1", "2"):
        a = h["alpha" + name]
        d = np.array([np.cos(a), np.sin(a)])
        damp += damping * np.outer(d, d)
    k_lin = stiff + np.array([[0.0, -mu * h["k3"]], [0.0, h["k3"]]])
    return h["mass"] * np.eye(2), damp, k_lin


def hoffmann_mu_crit() -> float:
    """Closed-form flutter threshold of the undamped model: the eigenvalues kappa of
    M^-1 K merge when (k_zz - k_yy - k3)^2 + 4 k_yz (k_zy - mu k3) = 0."""
    _, _, k0 = hoffmann_matrices(0.0)
    k3 = HOFFMANN["k3"]
    kzz, kzy, kyz, kyy = k0[0, 0], k0[0, 1], k0[1, 0], k0[1, 1] - k3
    return ((kzz - kyy - k3) ** 2 / (4 * kyz) + kzy) / k3


def ground_patch(y: float = 0.0, half: float = 0.5, n: int = 3):
    """A fixed rigid square patch in the plane y (nodes of an n x n grid)."""
    g = np.linspace(-half, half, n)
    xx, zz = np.meshgrid(g, g, indexing="ij")
    nodes = np.stack([xx, np.full(xx.shape, y), zz], -1).reshape(-1, 3)
    return FixedBody(rigid_body("ground", 1.0, nodes))


__all__ = [
    "HOFFMANN",
    "CartesianChart",
    "annulus_nodes",
    "ground_patch",
    "hoffmann_matrices",
    "hoffmann_mu_crit",
    "hoffmann_system",
    "lumped_modal_body",
]
