"""The compiled physics of the elastic multibody engine, written once for all lanes.

Each function here runs :data:`~fuzzymbs.mbs.kernels.simd.LANES` samples (lanes: 4, or 8
with ``FUZZYMBS_LANES=8``) per SIMD vector (:mod:`~fuzzymbs.mbs.kernels.simd`); a single
sample runs as a block whose lanes repeat it. The modules follow the right-hand
side's data flow:

* :mod:`~fuzzymbs.mbs.kernels.layout`: the compiled system's table columns,
  work-array rows and status codes;
* :mod:`~fuzzymbs.mbs.kernels.kinematics`: frame rotations, node positions and
  velocities, generalised forces of node forces;
* :mod:`~fuzzymbs.mbs.kernels.charts`: master-surface charts (arctangent, cell
  look-up);
* :mod:`~fuzzymbs.mbs.kernels.contact`: penalty contact with regularised
  Coulomb friction, one pass;
* :mod:`~fuzzymbs.mbs.kernels.rhs`: the right-hand side (springs, nodal
  forces, contact, equations of motion) and batched evaluation;
* :mod:`~fuzzymbs.mbs.kernels.rk4`: fixed-step RK4 over a batch of blocks;
* :mod:`~fuzzymbs.mbs.kernels.jacobian`: the right-hand side's Jacobian, for
  linearly implicit integrators.

Nothing here is imported by ``import fuzzymbs``: the modules load (and Numba
compiles or loads its cache) on first use.
"""
