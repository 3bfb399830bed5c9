"""Finite-element bodies: meshes, assembly with scikit-fem, modal reduction.

Typical use::

    from fuzzymbs.fe import ElasticBody, annulus_mesh, faces_in_region

    mesh = annulus_mesh(0.1, 0.2, 0.01, 6, 48, 1)
    disc = ElasticBody(mesh, 210e9, 0.3, 7850, fixed="inner", name="disc")
    modal_disc = disc.reduce(30, node_sets={"patch": ...}, face_sets={"patch": ...})
"""

from fuzzymbs.fe.elastic_body import ElasticBody
from fuzzymbs.fe.meshes import (
    annulus_mesh,
    box_mesh,
    bridge_mesh,
    mesh_nodes,
    read_mesh,
    transform_mesh,
    with_named_boundaries,
)
from fuzzymbs.fe.reduction import (
    ReducedBasis,
    craig_bampton,
    modal_truncation,
    reduce_body,
    static_correction,
)
from fuzzymbs.fe.surfaces import (
    boundary_faces,
    boundary_nodes,
    face_shape_functions,
    faces_in_region,
    nodes_in_region,
)

__all__ = [
    "ElasticBody",
    "ReducedBasis",
    "annulus_mesh",
    "boundary_faces",
    "boundary_nodes",
    "box_mesh",
    "bridge_mesh",
    "craig_bampton",
    "face_shape_functions",
    "faces_in_region",
    "mesh_nodes",
    "modal_truncation",
    "nodes_in_region",
    "read_mesh",
    "reduce_body",
    "static_correction",
    "transform_mesh",
    "with_named_boundaries",
]
