"""Node, face and boundary selections that match nothing are errors saying why."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import (
    boundary_faces,
    boundary_nodes,
    box_mesh,
    faces_in_region,
    mesh_nodes,
    nodes_in_region,
    with_named_boundaries,
)

# 2 x 2 x 1 27-node hexahedra on 0.06 x 0.04 x 0.015 m: a 5 x 5 x 3 node grid,
# node spacing 0.015 m in x, 0.01 m in y, 0.0075 m in z
PAD = box_mesh(0.06, 0.04, 0.015, 2, 2, 1)
TOLERANCE = 1e-9  # m, against round-off in the node coordinates


def left_half(x):
    return x[0] <= 0.03 + TOLERANCE


def test_non_empty_selections_are_unchanged():
    # reference: the nodes of the 5 x 5 x 3 grid picked by their coordinates directly
    nodes = mesh_nodes(PAD)
    on_top = np.flatnonzero(np.abs(nodes[:, 2] - 0.015) < TOLERANCE)
    expected = on_top[nodes[on_top, 0] <= 0.03 + TOLERANCE]
    selected = nodes_in_region(PAD, "top", left_half)
    np.testing.assert_array_equal(selected, expected)
    assert selected.size == 3 * 5  # x = 0, 0.015, 0.03 times five y positions
    faces = faces_in_region(PAD, "top", left_half)
    assert faces.shape == (2, 9)  # the two top faces of the elements with x <= 0.03
    assert set(np.unique(faces)) == set(selected)
    np.testing.assert_array_equal(nodes_in_region(PAD, "top"), on_top)
    np.testing.assert_array_equal(boundary_nodes(PAD, "top"), on_top)


def test_predicate_matching_only_other_nodes_names_the_boundary():
    def below_mid_plane(x):
        return x[2] < 0.0075

    message = _error(nodes_in_region, PAD, "top", below_mid_plane)
    assert "predicate test_predicate_matching_only_other_nodes_names_the_boundary" in message
    assert "below_mid_plane selects no node on boundary 'top'" in message
    assert "z [0.015, 0.015] m" in message  # where the boundary's nodes lie
    assert "rejects all 25 of its nodes" in message
    assert "accepts 25 nodes elsewhere in the mesh" in message and "boundary name" in message
    assert "The mesh spans x [0, 0.06], y [0, 0.04], z [0, 0.015] m" in message


def test_predicate_matching_nothing_at_all():
    # a typical mistake: millimetres instead of metres
    message = _error(nodes_in_region, PAD, "bottom", lambda x: x[0] > 30.0)
    assert "<lambda> selects no node on boundary 'bottom'" in message
    assert "accepts no node of the mesh at all" in message
    assert "units [m]" in message and "x [0, 0.06]" in message


def test_faces_with_some_passing_nodes_say_so():
    # only the x = 0 edge of the top face passes: nodes, but not a single whole face
    message = _error(faces_in_region, PAD, "top", lambda x: x[0] < TOLERANCE)
    assert "selects no face on boundary 'top'" in message
    assert "5 of its 25 nodes pass (spanning x [0, 0], y [0, 0.04], z [0.015, 0.015] m)" in message
    assert "every one of its nodes passes" in message
    # the same predicate selects those five nodes
    assert nodes_in_region(PAD, "top", lambda x: x[0] < TOLERANCE).size == 5


def test_predicate_that_only_works_on_boundary_nodes_still_gets_a_clear_error():
    top = boundary_nodes(PAD, "top")

    def wrong_everywhere_else(x):
        if x.shape[1] != top.size:
            raise IndexError("only for the top nodes")
        return np.zeros(x.shape[1], dtype=bool)

    message = _error(nodes_in_region, PAD, "top", wrong_everywhere_else)
    assert "rejects all 25 of its nodes" in message and "elsewhere" not in message


def test_empty_named_boundary_is_refused():
    mesh = PAD.with_boundaries({**PAD.boundaries, "seal": np.zeros(0, dtype=np.int64)})
    for select in (boundary_faces, boundary_nodes, nodes_in_region, faces_in_region):
        message = _error(select, mesh, "seal")
        assert "boundary 'seal' of this mesh holds no facet" in message
        assert "'top'" in message  # the non-empty names offered instead


def test_boundary_test_selecting_no_facet():
    message = _error(with_named_boundaries, PAD, {"friction": lambda x: x[2] > 0.015 * 1000})
    assert re.search(r"boundary 'friction' \(test \S*<lambda>\) selects no boundary facet", message)
    assert "rejects all 18 boundary vertices" in message  # the 3 x 3 x 2 element corners
    assert "x [0, 0.06], y [0, 0.04], z [0, 0.015] m" in message


def test_boundary_test_passing_an_edge_only():
    def bottom_left_edge(x):
        return (x[0] < TOLERANCE) & (x[2] < TOLERANCE)

    message = _error(with_named_boundaries, PAD, {"edge": bottom_left_edge})
    # the vertices (corners of order-1 facets) on that edge: y = 0, 0.02, 0.04
    assert "3 of the 18 boundary vertices pass (spanning x [0, 0], y [0, 0.04], z [0, 0] m)" in (
        message
    )
    assert "only when every vertex passes" in message
    message = _error(with_named_boundaries, PAD, {"edge": lambda x: np.ones(3, dtype=bool)})
    assert re.search(r"test of boundary 'edge' must return one boolean per vertex", message)


def _error(select, *args):
    with pytest.raises(InvalidParameterError) as error:
        select(*args)
    return str(error.value)


def test_elastic_body_node_set_refuses_empty_predicates_and_lists():
    from fuzzymbs.fe import ElasticBody

    body = ElasticBody(PAD, youngs_modulus=210e9, poisson_ratio=0.3, density=7850.0)
    # non-empty: the same 15 nodes as the boundary-free predicate on the raw coordinates
    nodes = mesh_nodes(PAD)

    def top_left(x):
        return (np.abs(x[2] - 0.015) < TOLERANCE) & (x[0] <= 0.03 + TOLERANCE)

    expected = np.flatnonzero(top_left(nodes.T))
    np.testing.assert_array_equal(body.node_set(top_left), expected)
    assert expected.size == 15

    def above_the_pad(x):
        return x[2] > 0.02

    message = r"above_the_pad selects no node.*z \[0, 0.015\]"
    with pytest.raises(InvalidParameterError, match=message):
        body.node_set(above_the_pad)
    with pytest.raises(InvalidParameterError, match="is empty"):
        body.node_set([])
