"""Geometrically nonlinear reference solutions: the spin-up beam, the flexible slider-crank.

The problem is the classic benchmark of Kane, Ryan & Banerjee (J. Guidance
Control Dyn. 10 (1987) 139): a planar cantilever clamped at the centre of a
hub of radius 0 whose angle is prescribed as

    theta(t) = (Omega_s / T_s) (t^2 / 2 + (T_s / 2 pi)^2 (cos(2 pi t / T_s) - 1)),  t < T_s,
    theta(t) = Omega_s (t - T_s / 2),                                             t >= T_s,

so the hub spins up smoothly (theta'' = 0 at both ends of the ramp) to Omega_s.
The beam data default to Kane's (SI): L = 8 m, E = 6.8952e10 Pa,
rho = 2766.7 kg/m^3, A = 7.2968e-5 m^2, I = 8.2189e-9 m^4. No gravity, no
damping. The output is the tip's deflection perpendicular to the hub's x axis,
d = (-sin theta, cos theta) . p with p the tip position in the inertial frame;
d < 0 means the tip lags behind the hub.

This is independent of the floating-frame code under test: the beam is a chain
of Crisfield's planar co-rotational Euler-Bernoulli elements (M. A. Crisfield,
Non-linear Finite Element Analysis of Solids and Structures, vol. 1, Wiley
1991, section 7.3), i.e. geometrically exact up to the discretisation, so the
membrane (centrifugal) stiffening that linear floating-frame theory misses,
which is what the benchmark tests, comes out of the geometry by itself. Each
element has the axial force N = EA (l - l0) / l0, the end moments
[M1, M2] = EI / l0 [[4, 2], [2, 4]] [t1, t2] from the end rotations t1, t2
relative to the chord, and the nodal forces B^T [N, M1, M2]; the tangent
stiffness is Crisfield's exact one. Node 0 sits at the origin with its
rotation prescribed as theta(t) (the clamp).

The mass is lumped (HRZ): rho A l0 / 2 per element and node in translation and
rho A l0^3 / 78 in rotation. Lumped point masses keep the inertial-frame
equations M q'' = -f_int(q, theta(t)) free of any velocity-dependent inertia
term and of inertial coupling to the prescribed clamp; the rotary inertia is
an O(l0^2) discretisation artefact (the true rho I is negligible here) that
vanishes as the mesh is refined, which the convergence study below confirms.

Coordinates. Those equations are integrated, by default, in hub-frame
coordinates p (inertial position R(theta) p, nodal rotation theta + psi).
For point masses and an objective element this change of variables is exact
and only adds the textbook terms m (2 theta' G p' + theta'' G p - theta'^2 p)
and J theta''. Integrating in inertial coordinates (``frame="inertial"``) is
kept as a cross-check but is much slower: the rigid rotation turns the stiff
axial directions (up to ~8e4 rad/s at 64 elements) by Omega h within a step,
so Radau's frozen Jacobian leaks axial stiffness into bending and its Newton
iteration fails unless h^3 Omega omega_axial^2 is below ~1. At 8 elements
that caps the step near 2 ms (24 s and 39 s per run at 4 and 10 rad/s,
against 3 s and 5 s in hub coordinates), and it gets worse as the mesh is
refined. Its ~8 m coordinates also carry round-off that stalls Newton below
atol ~ 1e-9. At 8 elements, rtol = 1e-8 and atol = 1e-9, the two variants
agree to 1.5e-9 (4 rad/s) and 6.6e-10 (10 rad/s) of max |d|.

The first-order system is stiff, so it is integrated with SciPy's Radau and
the exact analytic Jacobian, assembled as a sparse (banded) matrix.

Convergence, measured at the defaults (64 elements, rtol = 1e-8,
atol = 1e-9; 3.5 to 7 s per run on one core). ``delta`` is the largest
difference over 0 <= t <= 20 s (0.1 s samples) relative to max |d|:

    Omega_s  max |d|   at t   d(20 s)    delta: 128 elements   delta: tolerances
    [rad/s]  [m]       [s]    [m]        and tolerances / 10   / 10 alone
    1        0.1421    7.1    -0.000139  1.8e-4                1.3e-8
    2.5      0.3467    7.0     0.000093  1.9e-4                3.3e-9
    4        0.5337    6.8    -0.007094  2.0e-4                1.5e-9
    10       1.0833    6.2    -0.002488  3.2e-4                6.6e-10

The mesh error is O(l0^2) (at 4 rad/s the change on doubling 16 -> 32 -> 64
-> 128 elements is 3.2e-3, 8.1e-4, 2.0e-4), so the defaults' own
discretisation error is about 4/3 of the last column but one, at most
~4e-4 of max |d|; the time integration error is negligible beside it.
The small residual oscillation after the spin-up (d(20 s)) is itself only
accurate to that absolute level, i.e. to ~10 % at 10 rad/s.

Small-amplitude check: for the non-rotating beam the first transverse
frequency of the default mesh is 2.91037 rad/s against the Euler-Bernoulli
clamped-free value 1.8751^2 sqrt(EI / (rho A L^4)) = 2.91073 rad/s
(-1.2e-4; 18.232 and 51.031 against 18.241 and 51.077 rad/s for the next two).

The same element, lumping and integrator give the flexible slider-crank of
``fuzzymbs.models.mechanisms.slider_crank`` (``slider_crank_reference``; the
model, its coordinates and its convergence are described there).
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp
from scipy.integrate import solve_ivp

#: Elements used by default (shown converged, see the module docstring).
DEFAULT_ELEMENTS = 64
#: Default relative and absolute tolerances of the Radau integration.
DEFAULT_RTOL = 1e-8
DEFAULT_ATOL = 1e-9


def spin_up_angle(
    t: np.ndarray | float, spin_speed: float, spin_up_time: float = 15.0, derivative: int = 0
) -> np.ndarray:
    """Prescribed hub angle of the Kane et al. spin-up manoeuvre, or its rates.

    Parameters
    ----------
    t : array_like
        Time [s].
    spin_speed : float
        Final hub speed Omega_s [rad/s].
    spin_up_time : float, optional
        Duration T_s of the spin-up [s].
    derivative : {0, 1, 2}, optional
        Return theta [rad], theta' [rad/s] or theta'' [rad/s^2].

    Returns
    -------
    numpy.ndarray
        theta(t) or the requested time derivative.
    """
    t = np.asarray(t, dtype=float)
    ts = spin_up_time
    w = 2.0 * np.pi / ts
    rate = spin_speed / ts
    if derivative == 0:
        ramp = rate * (0.5 * t**2 + (np.cos(w * t) - 1.0) / w**2)
        after = spin_speed * (t - 0.5 * ts)
    elif derivative == 1:
        ramp = rate * (t - np.sin(w * t) / w)
        after = np.full_like(t, spin_speed)
    elif derivative == 2:
        ramp = rate * (1.0 - np.cos(w * t))
        after = np.zeros_like(t)
    else:
        raise ValueError("derivative must be 0, 1 or 2")
    return np.where(t < ts, ramp, after)


class CorotationalBeam:
    """Cantilever of planar co-rotational Euler-Bernoulli beam elements.

    The beam lies initially straight along the x axis from the origin. The
    unknowns are the displacements (from that straight configuration) and
    rotations of nodes 1..n, ordered node by node,
    ``q = [ux1, uy1, phi1, ux2, uy2, phi2, ...]`` (so the stiffness is
    banded); node 0 is held at the origin and its rotation is the prescribed
    clamp angle. Displacements rather than positions keep the element
    stretch free of round-off (see ``_element_state``).

    Parameters
    ----------
    elements : int
        Number of equal elements n.
    length : float
        Beam length L [m].
    youngs_modulus : float
        Young's modulus E [Pa].
    density : float
        Mass density rho [kg/m^3].
    area : float
        Cross-section area A [m^2].
    second_moment : float
        Second moment of area I [m^4] about the bending axis.
    """

    def __init__(
        self,
        elements: int,
        length: float,
        youngs_modulus: float,
        density: float,
        area: float,
        second_moment: float,
    ) -> None:
        if elements < 1:
            raise ValueError("elements must be at least 1")
        self.elements = n = int(elements)
        self.l0 = l0 = length / n
        self.ea = youngs_modulus * area
        self.ei = youngs_modulus * second_moment
        self.size = 3 * n

        # HRZ lumping: each element gives both its nodes half its mass and
        # rho A l0^3 / 78 of rotary inertia; the tip node has one element.
        m_el = density * area * l0
        per_node = np.full(n, 2.0)
        per_node[-1] = 1.0
        self.mass = np.repeat(per_node, 3) * np.tile([m_el / 2, m_el / 2, m_el * l0**2 / 78], n)

        # Free-dof index (node-0 dofs are -1) of each element's six dofs.
        self.dofs = (3 * np.arange(n)[:, None] + np.arange(6)[None, :]) - 3
        # The stiffness pattern is fixed (block tridiagonal), so it is built
        # once as a CSC matrix, and every entry of the element 6x6 blocks is
        # mapped to its slot in the CSC data array; assembly is then a single
        # bincount instead of a COO -> CSC conversion per Jacobian call.
        rows = np.repeat(self.dofs, 6, axis=1).ravel()
        cols = np.tile(self.dofs, (1, 6)).ravel()
        self._keep = (rows >= 0) & (cols >= 0)
        rows, cols = rows[self._keep], cols[self._keep]
        pattern = sp.csc_matrix((np.ones(rows.size), (rows, cols)), shape=(self.size, self.size))
        pattern.sum_duplicates()
        pattern.sort_indices()
        #: CSC structure of the tangent stiffness (shared by every call)
        self.indptr = pattern.indptr
        self.indices = pattern.indices
        self.nnz = pattern.nnz
        self._slot = np.array(
            [
                pattern.indptr[c]
                + np.searchsorted(pattern.indices[pattern.indptr[c] : pattern.indptr[c + 1]], r)
                for r, c in zip(rows, cols, strict=True)
            ]
        )

    def _element_state(self, q: np.ndarray, theta: float):
        """Chord geometry and end loads of every element (vectorised).

        Returns the chord length l, the chord direction cosines c and s, the
        axial force N and the end moments M1, M2, each of shape (n,).
        """
        nodes = q.reshape(self.elements, 3)
        # node 0 is at the origin with rotation theta (and no displacement);
        # the chord is built from displacement differences so that the
        # stretch below keeps its digits (see there)
        du = np.empty(self.elements)
        dy = np.empty(self.elements)
        du[0], dy[0] = nodes[0, 0], nodes[0, 1]
        np.subtract(nodes[1:, 0], nodes[:-1, 0], out=du[1:])
        np.subtract(nodes[1:, 1], nodes[:-1, 1], out=dy[1:])
        dx = self.l0 + du
        phi = np.concatenate(([theta], nodes[:, 2]))
        l = np.sqrt(dx * dx + dy * dy)
        c = dx / l
        s = dy / l
        # End rotations relative to the chord, taken through atan2 of the
        # sine and cosine of (phi - beta): in inertial coordinates the nodal
        # angles grow without bound as the hub spins (over 100 rad at
        # 10 rad/s) but the local ones stay small, so wrapping them to
        # (-pi, pi] is exact and avoids 2 pi jumps.
        cp, sp_ = np.cos(phi), np.sin(phi)
        t1 = np.arctan2(c * sp_[:-1] - s * cp[:-1], c * cp[:-1] + s * sp_[:-1])
        t2 = np.arctan2(c * sp_[1:] - s * cp[1:], c * cp[1:] + s * sp_[1:])
        # l - l0 written as (l^2 - l0^2) / (l + l0) with l^2 - l0^2 expanded
        # in the displacement differences: no cancellation, so the axial
        # force (EA / l0 ~ 4e7 N/m times a strain ~1e-4) carries no
        # round-off from the ~8 m nodal coordinates. That round-off would
        # otherwise put noise of ~1e-6 m/s^2 on the accelerations, enough to
        # stall Radau's Newton iteration at atol ~ 1e-10.
        stretch = (du * (2.0 * self.l0 + du) + dy * dy) / (l + self.l0)
        axial = (self.ea / self.l0) * stretch
        k_b = self.ei / self.l0
        m1 = k_b * (4.0 * t1 + 2.0 * t2)
        m2 = k_b * (2.0 * t1 + 4.0 * t2)
        return l, c, s, axial, m1, m2

    def internal_force(self, q: np.ndarray, theta: float) -> np.ndarray:
        """Internal nodal force vector f_int(q) on the free dofs [N, N m].

        Parameters
        ----------
        q : numpy.ndarray
            Free coordinates, shape (3 n,).
        theta : float
            Prescribed rotation of the clamped node 0 [rad].

        Returns
        -------
        numpy.ndarray
            f_int, shape (3 n,); the equations of motion are M q'' = -f_int.
        """
        nodal = self._nodal_forces(*self._element_state(q, theta))
        # free node k (global node k + 1); node 0 (clamped) is dropped
        return nodal[1:].ravel()

    @staticmethod
    def _nodal_forces(l, c, s, axial, m1, m2) -> np.ndarray:
        """Internal forces on every node 0..n, shape (n + 1, 3), from ``_element_state``."""
        # B^T [N, M1, M2] with the rows of B: r, e3 - z / l, e6 - z / l,
        # r = (-c, -s, 0, c, s, 0), z = (s, -c, 0, -s, c, 0); written out, the
        # end-2 force is (c N + s V, s N - c V) with V = (M1 + M2) / l the
        # shear, and the end-1 force is its opposite.
        shear = (m1 + m2) / l
        fx = c * axial + s * shear
        fy = s * axial - c * shear
        # node k is end 1 of element k and end 2 of element k - 1
        f = np.zeros((l.size + 1, 3))
        f[1:, 0] = fx
        f[1:, 1] = fy
        f[1:, 2] = m2
        f[:-1, 0] -= fx
        f[:-1, 1] -= fy
        f[:-1, 2] += m1
        return f

    def tangent_stiffness(self, q: np.ndarray, theta: float) -> sp.csc_matrix:
        """Exact tangent stiffness d f_int / d q on the free dofs (sparse).

        Crisfield's consistent tangent of the co-rotational element,
        K = B^T D B + N z z^T / l + (M1 + M2) (r z^T + z r^T) / l^2, with
        D = diag(EA / l0, EI / l0 [[4, 2], [2, 4]]).

        Parameters
        ----------
        q : numpy.ndarray
            Free coordinates, shape (3 n,).
        theta : float
            Prescribed rotation of the clamped node 0 [rad].

        Returns
        -------
        scipy.sparse.csc_matrix
            Shape (3 n, 3 n).
        """
        k_el = self.element_stiffness(q, theta).reshape(self.elements, 36)
        data = np.bincount(self._slot, weights=k_el.ravel()[self._keep], minlength=self.nnz)
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.size, self.size))

    def element_stiffness(self, q: np.ndarray, theta: float) -> np.ndarray:
        """Exact tangent stiffness of every element, node 0's dofs included.

        Parameters
        ----------
        q : numpy.ndarray
            Free coordinates, shape (3 n,).
        theta : float
            Prescribed rotation of node 0 [rad].

        Returns
        -------
        numpy.ndarray
            Shape (n, 6, 6): element k's stiffness on the dofs
            (x, y, phi) of its nodes k and k + 1 (see ``tangent_stiffness``).
        """
        l, c, s, axial, m1, m2 = self._element_state(q, theta)
        zero = np.zeros_like(c)
        r = np.stack([-c, -s, zero, c, s, zero], axis=1)  # dl / dq_e
        z = np.stack([s, -c, zero, -s, c, zero], axis=1)  # l dbeta / dq_e
        b1 = -z / l[:, None]
        b2 = b1.copy()
        b1[:, 2] += 1.0
        b2[:, 5] += 1.0
        k_b = self.ei / self.l0

        def outer(a, b):
            return a[:, :, None] * b[:, None, :]

        return (
            (self.ea / self.l0) * outer(r, r)
            + k_b
            * (4.0 * outer(b1, b1) + 2.0 * (outer(b1, b2) + outer(b2, b1)) + 4.0 * outer(b2, b2))
            + (axial / l)[:, None, None] * outer(z, z)
            + ((m1 + m2) / l**2)[:, None, None] * (outer(r, z) + outer(z, r))
        )

    def reference_positions(self) -> np.ndarray:
        """Positions of nodes 1..n in the straight reference configuration, shape (3 n,).

        The x, y entries are the nodal coordinates of the unstressed beam along
        x, the rotation entries are zero; position = this + q.
        """
        x = np.zeros(self.size)
        x[0::3] = self.l0 * np.arange(1, self.elements + 1)
        return x

    def tip_position(self, q: np.ndarray) -> np.ndarray:
        """(x, y) of the free end [m] for coordinates ``q`` of shape (3 n, ...)."""
        tip = q[self.size - 3 : self.size - 1].copy()
        tip[0] += self.elements * self.l0
        return tip


def clamped_free_frequencies(
    elements: int = DEFAULT_ELEMENTS,
    count: int = 3,
    length: float = 8.0,
    youngs_modulus: float = 6.8952e10,
    density: float = 2766.7,
    area: float = 7.2968e-5,
    second_moment: float = 8.2189e-9,
) -> np.ndarray:
    """Lowest transverse natural frequencies of the non-rotating FE beam.

    Small-amplitude sanity check of the discretisation: the eigenvalues of
    M^-1 K at the straight configuration, transverse dofs only (about the
    straight beam the axial dofs decouple), to compare with the
    Euler-Bernoulli clamped-free values beta_k^2 sqrt(EI / (rho A L^4)),
    beta_1 L = 1.8751.

    Parameters
    ----------
    elements : int, optional
        Number of elements.
    count : int, optional
        How many frequencies to return.
    length, youngs_modulus, density, area, second_moment : float, optional
        Beam data [m, Pa, kg/m^3, m^2, m^4].

    Returns
    -------
    numpy.ndarray
        The ``count`` lowest circular frequencies [rad/s], ascending.
    """
    beam = CorotationalBeam(elements, length, youngs_modulus, density, area, second_moment)
    k = beam.tangent_stiffness(np.zeros(beam.size), 0.0).toarray()
    transverse = np.sort(np.concatenate([np.arange(1, beam.size, 3), np.arange(2, beam.size, 3)]))
    k = k[np.ix_(transverse, transverse)]
    scale = 1.0 / np.sqrt(beam.mass[transverse])
    # symmetric form M^-1/2 K M^-1/2 keeps the eigenvalues real and accurate
    omega2 = np.linalg.eigvalsh(scale[:, None] * k * scale[None, :])
    return np.sqrt(omega2[:count])


def spin_up_tip_deflection(
    spin_speed: float,
    times: np.ndarray,
    spin_up_time: float = 15.0,
    elements: int = DEFAULT_ELEMENTS,
    length: float = 8.0,
    youngs_modulus: float = 6.8952e10,
    density: float = 2766.7,
    area: float = 7.2968e-5,
    second_moment: float = 8.2189e-9,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    frame: str = "hub",
) -> np.ndarray:
    """Tip deflection of the spin-up beam in the hub frame.

    Parameters
    ----------
    spin_speed : float
        Final hub speed Omega_s [rad/s].
    times : array_like
        Output times [s], ascending, all >= 0; the run starts at t = 0 from
        the straight beam at rest.
    spin_up_time : float, optional
        Duration T_s of the spin-up [s].
    elements : int, optional
        Number of co-rotational elements.
    length : float, optional
        Beam length L [m].
    youngs_modulus : float, optional
        Young's modulus E [Pa].
    density : float, optional
        Mass density rho [kg/m^3].
    area : float, optional
        Cross-section area A [m^2].
    second_moment : float, optional
        Second moment of area I [m^4].
    rtol, atol : float, optional
        Relative and absolute tolerances of the Radau integrator (``atol`` in
        m, rad, m/s and rad/s alike).
    frame : {"hub", "inertial"}, optional
        Coordinates the equations are integrated in (see the module
        docstring): "hub" (default, fast) or "inertial" (the same mechanics
        without any fictitious force, but about ten times slower already at
        8 elements and slower still on finer meshes; kept as a cross-check of
        the hub-frame inertia terms).

    Returns
    -------
    numpy.ndarray
        d(t) = (-sin theta, cos theta) . p_tip [m] at ``times``, positive
        towards +y of the hub frame (a tip lagging a positive spin-up gives
        d < 0).
    """
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size == 0:
        raise ValueError("times must be a non-empty 1-D array")
    if times[0] < 0.0 or np.any(np.diff(times) < 0.0):
        raise ValueError("times must be ascending and non-negative")
    if frame not in ("hub", "inertial"):
        raise ValueError('frame must be "hub" or "inertial"')

    beam = CorotationalBeam(elements, length, youngs_modulus, density, area, second_moment)
    size = beam.size
    y0 = np.zeros(2 * size)  # straight and at rest
    t_end = float(times[-1])
    if t_end == 0.0:
        return np.zeros_like(times)

    def angle(t: float, derivative: int = 0) -> float:
        return float(spin_up_angle(t, spin_speed, spin_up_time, derivative))

    if frame == "hub":
        rhs, jac = _hub_frame_equations(beam, angle)
    else:
        rhs, jac = _inertial_frame_equations(beam, angle)
    sol = solve_ivp(
        rhs, (0.0, t_end), y0, method="Radau", t_eval=times, jac=jac, rtol=rtol, atol=atol
    )
    if not sol.success:
        raise RuntimeError(f"spin-up integration failed: {sol.message}")
    tip = beam.tip_position(sol.y)
    if frame == "hub":
        return tip[1]
    theta = spin_up_angle(sol.t, spin_speed, spin_up_time)
    return -np.sin(theta) * tip[0] + np.cos(theta) * tip[1]


def _hub_frame_equations(beam: CorotationalBeam, angle):
    """Right-hand side and Jacobian of the equations of motion in hub-frame coordinates.

    With R(theta) p for every node's inertial position (p its hub-frame
    position) and theta + psi for its rotation, the lumped point masses obey
    exactly m (p'' + 2 theta' G p' + theta'' G p - theta'^2 p) = -f_p(p, psi)
    and J (psi'' + theta'') = -f_psi(p, psi), G = [[0, -1], [1, 0]], because
    the co-rotational element is objective (rotating every node by theta just
    rotates f_int with it). Node 0 has p = 0 and psi = 0; the unknowns are
    the displacements q = p - p_ref and psi.
    """
    size = beam.size
    inv_mass = 1.0 / beam.mass
    translational = np.tile([1.0, 1.0, 0.0], beam.elements)
    rotational = 1.0 - translational
    # G acting on every node's (x, y): (G u)_x = -u_y, (G u)_y = u_x
    x_dofs = np.arange(0, size, 3)
    g = sp.csc_matrix(
        (
            np.tile([1.0, -1.0], beam.elements),
            (np.stack((x_dofs + 1, x_dofs), 1).ravel(), np.stack((x_dofs, x_dofs + 1), 1).ravel()),
        ),
        shape=(size, size),
    )
    g.sort_indices()
    # The Jacobian [[0, I], [-M^-1 K - theta'' G + theta'^2 P, -2 theta' G]]
    # (P: the translational dofs) has a fixed pattern, as G and P fall inside
    # the full 3x3 diagonal blocks of K. So it is laid out once: a template
    # whose data are the 1-based positions of its entries in the value vector
    # [I entries, K-pattern entries, G entries], and each call just permutes.
    k_rows = beam.indices
    k_cols = np.repeat(np.arange(size), np.diff(beam.indptr))
    g_on_k = np.asarray(g[k_rows, k_cols]).ravel()
    p_on_k = np.where(k_rows == k_cols, translational[k_rows], 0.0)
    square = (size, size)
    ids = np.arange(1, size + beam.nnz + g.nnz + 1, dtype=float)
    template = sp.block_array(
        [
            [None, sp.csc_matrix((ids[:size], np.arange(size), np.arange(size + 1)), shape=square)],
            [
                sp.csc_matrix(
                    (ids[size : size + beam.nnz], beam.indices, beam.indptr), shape=square
                ),
                sp.csc_matrix((ids[size + beam.nnz :], g.indices, g.indptr), shape=square),
            ],
        ],
        format="csc",
    )
    order = template.data.astype(np.int64) - 1
    jac_structure = (template.indices, template.indptr)

    reference = beam.reference_positions()

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, w = y[:size], y[size:]
        p = reference + q  # hub-frame positions (and relative rotations)
        rate, accel = angle(t, 1), angle(t, 2)
        acc = -inv_mass * beam.internal_force(q, 0.0) + rate**2 * translational * p
        acc -= accel * rotational
        # Coriolis -2 theta' G w and Euler -theta'' G p on the (x, y) pairs
        acc[0::3] += 2.0 * rate * w[1::3] + accel * p[1::3]
        acc[1::3] -= 2.0 * rate * w[0::3] + accel * p[0::3]
        return np.concatenate((w, acc))

    def jac(t: float, y: np.ndarray) -> sp.csc_matrix:
        rate, accel = angle(t, 1), angle(t, 2)
        k = beam.tangent_stiffness(y[:size], 0.0)
        values = np.concatenate(
            (
                np.ones(size),
                -inv_mass[k_rows] * k.data - accel * g_on_k + rate**2 * p_on_k,
                -2.0 * rate * g.data,
            )
        )
        return sp.csc_matrix((values[order], *jac_structure), shape=(2 * size, 2 * size))

    return rhs, jac


def _inertial_frame_equations(beam: CorotationalBeam, angle):
    """Right-hand side and Jacobian of M q'' = -f_int(q, theta(t)), inertial coordinates."""
    size = beam.size
    inv_mass = 1.0 / beam.mass
    # CSC structure of the first-order Jacobian [[0, I], [-M^-1 K, 0]]:
    # column j < 3n holds column j of -M^-1 K (rows shifted down by 3n),
    # column 3n + j holds the single 1 in row j.
    jac_indptr = np.concatenate((beam.indptr, beam.nnz + np.arange(1, size + 1)))
    jac_indices = np.concatenate((beam.indices + size, np.arange(size)))

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return np.concatenate((y[size:], -inv_mass * beam.internal_force(y[:size], angle(t))))

    def jac(t: float, y: np.ndarray) -> sp.csc_matrix:
        k = beam.tangent_stiffness(y[:size], angle(t))
        data = np.concatenate((-inv_mass[beam.indices] * k.data, np.ones(size)))
        return sp.csc_matrix((data, jac_indices, jac_indptr), shape=(2 * size, 2 * size))

    return rhs, jac


# ---------------------------------------------------------------------------
# Flexible slider-crank
# ---------------------------------------------------------------------------

#: Crank length r, rod length l [m] and rod density [kg/m^3] of the slider-crank
#: (those of ``fuzzymbs.models.mechanisms.slider_crank``).
CRANK_LENGTH = 0.15
ROD_LENGTH = 0.3
STEEL_DENSITY = 7870.0
#: Elements and Radau tolerances of the slider-crank reference by default
#: (shown converged, see ``slider_crank_reference``).
SLIDER_CRANK_ELEMENTS = 64
SLIDER_CRANK_RTOL = 1e-8
SLIDER_CRANK_ATOL = 1e-10


def crank_angle(
    t: np.ndarray | float, crank_speed: float, spin_up_time: float = 0.0, derivative: int = 0
) -> np.ndarray:
    """Prescribed crank angle phi(t) [rad], or its rates, starting at phi(0) = 0.

    With ``spin_up_time`` T > 0 the crank spins up from rest as the spin-up
    beam's hub does (``spin_up_angle``: zero acceleration at both ends of the
    ramp) and turns at ``crank_speed`` after T; with T = 0 it turns at
    ``crank_speed`` from the start, phi = w t.
    """
    if spin_up_time > 0.0:
        return spin_up_angle(t, crank_speed, spin_up_time, derivative)
    t = np.asarray(t, dtype=float)
    if derivative not in (0, 1, 2):
        raise ValueError("derivative must be 0, 1 or 2")
    return (crank_speed * t, np.full_like(t, crank_speed), np.zeros_like(t))[derivative]


def rigid_slider_crank(
    angle: np.ndarray | float,
    rate: np.ndarray | float,
    acceleration: np.ndarray | float,
    crank_length: float = CRANK_LENGTH,
    rod_length: float = ROD_LENGTH,
) -> dict[str, np.ndarray]:
    """Kinematics of the rigid slider-crank, slider on the x axis (x > 0).

    Parameters
    ----------
    angle, rate, acceleration : array_like
        Crank angle phi from +x [rad] and its rates [rad/s, rad/s^2].
    crank_length, rod_length : float, optional
        r and l [m], l > r.

    Returns
    -------
    dict
        ``pin_acceleration``: the crank pin's acceleration, shape (2, ...)
        [m/s^2]; ``angle``, ``angle_rate`` and ``angle_acceleration``: the
        rod's angle beta = -asin(r sin(phi) / l) and its rates [rad, rad/s,
        rad/s^2]; ``slider`` and ``slider_acceleration``: the slider's x and
        x'' [m, m/s^2].
    """
    phi = np.asarray(angle, dtype=float)
    r, l = crank_length, rod_length
    cos, sin = np.cos(phi), np.sin(phi)
    # the pin's tangential and normal accelerations
    tangential, normal = r * acceleration, r * rate * rate
    # s = sin(-beta) = r sin(phi) / l and its rates; q = cos(beta)^2
    s = r / l * sin
    ds = r / l * cos * rate
    dds = r / l * (cos * acceleration - sin * rate * rate)
    q = 1.0 - s * s
    root = np.sqrt(q)
    return {
        "pin_acceleration": np.stack(
            (-sin * tangential - cos * normal, cos * tangential - sin * normal)
        ),
        "angle": -np.arcsin(s),
        "angle_rate": -ds / root,
        "angle_acceleration": -(dds * q + s * ds * ds) / (q * root),
        "slider": r * cos + l * root,
        "slider_acceleration": -sin * tangential
        - cos * normal
        - l * (ds * ds + s * dds * q) / (q * root),
    }


class _SliderCrankRod:
    """Equations of motion of the slider-crank's co-rotational rod.

    The rod's nodes are described in a frame with its origin at the crank pin
    p_A(t) and turned by a known angle beta(t): node k is at
    p_A + R(beta) (X_k + u_k) with X_k = (k l0, 0), and turned by
    beta + psi_k. The unknowns are

        z = [psi_0, u_1, v_1, psi_1, ..., u_{n-1}, v_{n-1}, psi_{n-1}, xi, psi_n]

    and their rates w = z', where xi is the slider's displacement along x from
    its rigid-mechanism position x_s(t): node n sits at (x_s + xi, 0), i.e. at
    frame displacement u_n = c(t) + xi d(t), with
    c = R^T (x_s - p_Ax, -p_Ay) - (l, 0) and d = R^T e_x. Node 0 sits at the
    frame origin. So the crank pin's prescribed position and the slide's
    y = 0 are eliminated exactly, and the rest is an ODE.

    ``frame="rod"`` takes beta(t) as the rigid mechanism's rod angle, so c = 0
    and z = 0, w = 0 is the rigid motion: the unknowns are the deformation,
    and the stiff axial directions stay put in them, which is what lets
    Radau take long steps over the axial modes with a Jacobian that is only
    rarely updated. ``frame="fixed"`` takes beta = 0 (a translating frame
    with inertial directions, about 100 times slower; kept as a cross-check
    of the frame terms).

    With lumped masses and an objective element, the equations are exactly
    m (u'' + 2 beta' G u' + beta'' G p - beta'^2 p + R^T a_A) = -f_u (p = X + u)
    for the inner nodes, J (psi'' + beta'') = -f_psi for every rotation, and
    (m_n + m_s) (x_s'' + xi'') = -d . f_n for the slider, with f the internal
    forces in the frame and G = [[0, -1], [1, 0]].
    """

    def __init__(
        self,
        beam: CorotationalBeam,
        slider_mass: float,
        crank_speed: float,
        spin_up_time: float,
        crank_length: float,
        frame: str,
    ) -> None:
        if beam.elements < 2 or beam.elements % 2:
            raise ValueError("the rod needs an even element count (a node at its midpoint)")
        if frame not in ("rod", "fixed"):
            raise ValueError('frame must be "rod" or "fixed"')
        self.beam = beam
        self.slider_mass = slider_mass
        self.crank_speed = crank_speed
        self.spin_up_time = spin_up_time
        self.crank_length = crank_length
        self.frame = frame
        n = beam.elements
        self.size = size = 3 * n
        self.length = n * beam.l0
        # z index and weight of every node's (x, y, phi): node 0's position is
        # held (weight 0), node n's x and y are both xi (weights d(t))
        index = np.arange(-2, 3 * n + 1).reshape(n + 1, 3)
        index[0, :2] = 0
        index[n] = [size - 2, size - 2, size - 1]
        self.index = index.ravel()
        self._weight = np.ones((n + 1, 3))
        self._weight[0, :2] = 0.0
        # diagonal mass in z: HRZ as in CorotationalBeam; the slider adds to xi
        end_rotary = beam.mass[-1]
        self.mass = np.concatenate(
            ([end_rotary], beam.mass[:-3], [beam.mass[-3] + slider_mass, end_rotary])
        )
        self.tx = np.arange(1, size - 2, 3)  # inner nodes' u
        self.ty = self.tx + 1  # inner nodes' v
        self.rotations = np.concatenate(([0], np.arange(3, size - 2, 3), [size - 1]))
        self.reference = np.arange(1, n) * beam.l0  # inner nodes' X
        self.midpoint = n // 2
        # element e's six dofs are those of nodes e and e + 1
        self._element_dofs = 3 * np.arange(n)[:, None] + np.arange(6)[None, :]
        self._rows = np.repeat(self.index[self._element_dofs], 6, axis=1).ravel()
        self._cols = np.tile(self.index[self._element_dofs], (1, 6)).ravel()
        # the frame terms couple each inner node's (u, v) pair
        self._pair_rows = np.concatenate((self.tx, self.ty, self.tx, self.ty))
        self._pair_cols = np.concatenate((self.tx, self.ty, self.ty, self.tx))
        # Radau's Newton iteration evaluates the right-hand side at the same
        # few times over and over
        self.kinematics = functools.lru_cache(maxsize=16)(self._kinematics)

    def _kinematics(self, t: float):
        """Frame rates beta', beta'', R^T a_A, c, d and the slider's x_s, x_s''.

        (Cached as ``kinematics``; the arrays returned are shared, not to be
        modified.)
        """
        phi = [float(crank_angle(t, self.crank_speed, self.spin_up_time, k)) for k in range(3)]
        rigid = rigid_slider_crank(*phi, self.crank_length, self.length)
        pin_acc = rigid["pin_acceleration"]
        if self.frame == "rod":
            beta = float(rigid["angle"])
            rate, accel = float(rigid["angle_rate"]), float(rigid["angle_acceleration"])
            offset = np.zeros(2)  # exactly: the rigid mechanism's node n is at (l, 0)
        else:
            beta = rate = accel = 0.0
            r = self.crank_length
            offset = np.array(
                [rigid["slider"] - r * np.cos(phi[0]) - self.length, -r * np.sin(phi[0])]
            )
        cb, sb = np.cos(beta), np.sin(beta)
        frame_acc = np.array(
            [cb * pin_acc[0] + sb * pin_acc[1], -sb * pin_acc[0] + cb * pin_acc[1]]
        )
        slide = np.array([cb, -sb])
        slider, slider_acc = float(rigid["slider"]), float(rigid["slider_acceleration"])
        return rate, accel, frame_acc, offset, slide, slider, slider_acc

    def _displacements(self, z: np.ndarray, offset: np.ndarray, slide: np.ndarray):
        """Frame displacements (n + 1, 3) of every node, and the node weights."""
        weight = self._weight.copy()
        weight[-1, :2] = slide
        nodal = (z[self.index] * weight.ravel()).reshape(-1, 3)
        nodal[-1, :2] += offset
        return nodal, weight

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """First-order right-hand side (z', w')."""
        size = self.size
        z, w = y[:size], y[size:]
        rate, accel, frame_acc, offset, slide, _, slider_acc = self.kinematics(t)
        nodal, weight = self._displacements(z, offset, slide)
        state = self.beam._element_state(nodal[1:].ravel(), nodal[0, 2])
        forces = self.beam._nodal_forces(*state) * weight
        g = np.bincount(self.index, weights=forces.ravel(), minlength=size)
        acc = -g / self.mass
        px = self.reference + z[self.tx]
        py = z[self.ty]
        acc[self.tx] += 2.0 * rate * w[self.ty] + accel * py + rate**2 * px - frame_acc[0]
        acc[self.ty] += -2.0 * rate * w[self.tx] - accel * px + rate**2 * py - frame_acc[1]
        acc[self.rotations] -= accel
        acc[size - 2] -= slider_acc
        return np.concatenate((w, acc))

    def jac(self, t: float, y: np.ndarray) -> sp.csc_matrix:
        """Exact Jacobian of ``rhs`` (sparse)."""
        size = self.size
        pairs = self.tx.size
        rate, accel, _, offset, slide, _, _ = self.kinematics(t)
        nodal, weight = self._displacements(y[:size], offset, slide)
        k_el = self.beam.element_stiffness(nodal[1:].ravel(), nodal[0, 2])
        wd = weight.ravel()[self._element_dofs]  # (n, 6)
        values = -(k_el * wd[:, :, None] * wd[:, None, :]).ravel() / self.mass[self._rows]
        frame_values = np.repeat([rate**2, rate**2, accel, -accel], pairs)
        stiffness = sp.coo_matrix(
            (
                np.concatenate((values, frame_values)),
                (
                    np.concatenate((self._rows, self._pair_rows)),
                    np.concatenate((self._cols, self._pair_cols)),
                ),
            ),
            shape=(size, size),
        )
        coriolis = sp.coo_matrix(
            (
                np.repeat([2.0 * rate, -2.0 * rate], pairs),
                (self._pair_rows[2 * pairs :], self._pair_cols[2 * pairs :]),
            ),
            shape=(size, size),
        )
        return sp.block_array([[None, sp.eye_array(size)], [stiffness, coriolis]], format="csc")

    def initial_state(self) -> np.ndarray:
        """State at t = 0: the straight, undeformed rod in the rigid motion.

        At t = 0 the crank is at phi = 0 (dead centre) turning at phi'(0)
        (0 for a spin-up), so the rigid rod turns about the crank pin at
        beta'(0) = -r phi'(0) / l with the slider at rest; in the frame that
        is the velocity field (beta'(0) - frame rate) G X.
        """
        size = self.size
        y0 = np.zeros(2 * size)
        phi = [float(crank_angle(0.0, self.crank_speed, self.spin_up_time, k)) for k in range(3)]
        spin = float(rigid_slider_crank(*phi, self.crank_length, self.length)["angle_rate"])
        relative = spin - self.kinematics(0.0)[0]
        y0[size + self.ty] = relative * self.reference
        y0[size + self.rotations] = relative
        return y0

    def outputs(self, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        """Midpoint deflection, slider position and pin force at times t, states y (2 size, T)."""
        size = self.size
        deflection = np.empty(t.size)
        slider = np.empty(t.size)
        force = np.empty(t.size)
        mid = 3 * self.midpoint - 2  # z index of the midpoint's u
        for i, (ti, yi) in enumerate(zip(t, y.T, strict=True)):
            _, _, _, offset, slide, slider_x, slider_acc = self.kinematics(ti)
            xi = yi[size - 2]
            # the chord from node 0 (the frame origin) to node n, and the
            # midpoint's offset across it (both in the frame: invariant)
            chord = np.array([self.length, 0.0]) + offset + xi * slide
            px = self.midpoint * self.beam.l0 + yi[mid]
            py = yi[mid + 1]
            deflection[i] = (chord[0] * py - chord[1] * px) / np.hypot(*chord)
            slider[i] = slider_x + xi
            # m_s (x_s'' + xi''), xi'' from the equations of motion
            force[i] = self.slider_mass * (self.rhs(ti, yi)[2 * size - 2] + slider_acc)
        return {
            "midpoint_deflection": deflection,
            "slider_position": slider,
            "slider_pin_force_x": force,
        }


def slider_crank_reference(
    times: np.ndarray,
    crank_speed: float = 150.0,
    youngs_modulus: float = 2.0e11,
    rod_width: float = 0.01,
    rod_height: float = 0.006,
    slider_mass: float = 0.1,
    elements: int = SLIDER_CRANK_ELEMENTS,
    rtol: float = SLIDER_CRANK_RTOL,
    atol: float = SLIDER_CRANK_ATOL,
    *,
    spin_up_time: float = 0.02,
    frame: str = "rod",
) -> dict[str, np.ndarray]:
    """Slider-crank with a geometrically nonlinear flexible rod.

    Parameters
    ----------
    times : array_like
        Output times [s], ascending, all >= 0; the run starts at t = 0.
    crank_speed : float, optional
        Final crank speed w [rad/s].
    youngs_modulus : float, optional
        Rod's Young's modulus E [Pa].
    rod_width, rod_height : float, optional
        Rod's section b and h [m] (A = b h, I = b h^3 / 12).
    slider_mass : float, optional
        Slider mass m_s [kg].
    elements : int, optional
        Co-rotational elements in the rod (even).
    rtol, atol : float, optional
        Radau tolerances (``atol`` in m, rad, m/s and rad/s alike).
    spin_up_time : float, optional
        Duration of the crank's spin-up from rest [s] (``crank_angle``);
        0 starts the crank at full speed with the rod in the rigid motion.
    frame : {"rod", "fixed"}, optional
        Frame of the coordinates (see ``_SliderCrankRod``).

    Returns
    -------
    dict
        ``midpoint_deflection`` [m], ``slider_position`` [m] and
        ``slider_pin_force_x`` [N], arrays over ``times``.
    """
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size == 0:
        raise ValueError("times must be a non-empty 1-D array")
    if times[0] < 0.0 or np.any(np.diff(times) < 0.0):
        raise ValueError("times must be ascending and non-negative")
    if spin_up_time < 0.0:
        raise ValueError("spin_up_time must be >= 0")
    beam = CorotationalBeam(
        elements,
        ROD_LENGTH,
        youngs_modulus,
        STEEL_DENSITY,
        rod_width * rod_height,
        rod_width * rod_height**3 / 12.0,
    )
    rod = _SliderCrankRod(beam, slider_mass, crank_speed, spin_up_time, CRANK_LENGTH, frame)
    y0 = rod.initial_state()
    t_end = float(times[-1])
    if t_end == 0.0:
        return rod.outputs(times, np.repeat(y0[:, None], times.size, axis=1))
    # atol / l0 on the rotations and their rates (see the docstring)
    tolerance = np.full(y0.size, float(atol))
    tolerance[rod.rotations] = tolerance[rod.size + rod.rotations] = atol / beam.l0
    sol = solve_ivp(
        rod.rhs,
        (0.0, t_end),
        y0,
        method="Radau",
        t_eval=times,
        jac=rod.jac,
        rtol=rtol,
        atol=tolerance,
    )
    if not sol.success:
        raise RuntimeError(f"slider-crank integration failed: {sol.message}")
    return rod.outputs(sol.t, sol.y)
