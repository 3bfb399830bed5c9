"""Multibody engine: modal bodies, force laws, contact, integrators, eigenvalues."""
