"""Finite-element bodies: meshes, assembly with scikit-fem, modal reduction."""
