"""The methods are objects: one registry, declared options, capabilities the code asks."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pytest

from fuzzymbs.errors import InvalidPlanError, UnsupportedOperationError
from fuzzymbs.fuzzy import Triangular, plan, run_count
from fuzzymbs.fuzzy.accumulate import StreamLayout
from fuzzymbs.fuzzy.influence import compute_influence
from fuzzymbs.fuzzy.methods import METHODS, Method, method_named
from fuzzymbs.fuzzy.methods.base import CountRequest
from fuzzymbs.fuzzy.methods.level_scheme import LevelScheme
from fuzzymbs.fuzzy.transform import ALL_METHODS, RoundsPlan
from fuzzymbs.study.studyfile import StudySection

PARAMETERS = {"x1": Triangular(1.0, 2.0, 3.0), "x2": Triangular(0.5, 1.0, 2.0)}


def _product(columns):
    return {"z": columns["x1"] * columns["x2"]}


def test_the_registry_lists_every_public_name_once():
    assert tuple(METHODS) == ("general", "reduced", "extended", "grid", "sparse", "adaptive")
    assert ALL_METHODS == tuple(METHODS)
    for name, cls in METHODS.items():
        assert cls.name == name and isinstance(method_named(name), cls)
    with pytest.raises(InvalidPlanError, match=r"unknown method 'fast'; valid methods: \['gen"):
        method_named("fast")


@pytest.mark.parametrize("name", list(METHODS))
def test_every_declared_option_is_checked_and_named_in_the_error(name):
    cls = METHODS[name]
    for declared in cls.options():
        assert declared.help  # every option says what it does (fuzzymbs info shows it)
        # a string is never a valid number, and a number never a list of names
        bad = 3 if declared.name == "nonmonotonic" else "three"
        with pytest.raises(InvalidPlanError, match=rf"^{declared.name} must be "):
            method_named(name, **{declared.name: bad})


def test_an_option_of_another_method_names_the_methods_that_use_it():
    with pytest.raises(InvalidPlanError, match=r"sparse_level=2 is only used by method='sparse'"):
        method_named("reduced", sparse_level=2)
    with pytest.raises(InvalidPlanError, match=r"'sparse' or 'adaptive', not 'grid'"):
        method_named("grid", search_points=400)
    # a method object carries its own options: none may be given beside it
    with pytest.raises(InvalidPlanError, match="give them to the method object"):
        method_named(method_named("sparse"), sparse_level=2)


@pytest.mark.parametrize("name", list(METHODS))
def test_capabilities_decide_what_a_plan_offers(name):
    scheme = plan(PARAMETERS, name, 2)
    cls = METHODS[name]
    assert isinstance(scheme, RoundsPlan) == cls.runs_in_rounds
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outputs = scheme.evaluate(_product)
        result = scheme.retransform(outputs)["z"]
    # one attribute decides influence for a result and for compute_influence alike
    if cls.supports_influence:
        gains = result.influence().gain  # (parameter, level); the point core has none
        assert gains.shape == (2, 3) and np.all(np.isfinite(gains[:, :-1]))
        again = compute_influence(scheme, outputs["z"], None)
        np.testing.assert_array_equal(again.gain, gains)
    else:
        with pytest.raises(UnsupportedOperationError, match=f"method='{name}'"):
            result.influence()
        with pytest.raises(UnsupportedOperationError, match=f"method='{name}'"):
            compute_influence(scheme, outputs["z"], None)
    if cls.has_corners:
        assert scheme.corner_index.shape == (3, 4)
    else:
        with pytest.raises(UnsupportedOperationError, match="corner bookkeeping"):
            scheme.corner_index  # noqa: B018
    if cls.interpolates:
        assert len(scheme.node_index) > 0
    else:
        with pytest.raises(UnsupportedOperationError, match="interpolating method"):
            scheme.node_index  # noqa: B018
    if cls.supports_streaming:
        assert StreamLayout(scheme).corners == cls.has_corners
    else:
        with pytest.raises(InvalidPlanError, match="from all samples at once"):
            StreamLayout(scheme)


@dataclass(frozen=True)
class ThreePoint(LevelScheme):
    """The example of docs/architecture.md: at every level the full factorial of each
    parameter's cut bounds and their midpoint."""

    name = "three-point"
    summary = "the cut bounds and midpoint of every parameter, all combined, at every level"

    def value_sets(self, names, cut_lower, cut_upper):
        middle = 0.5 * (cut_lower + cut_upper)
        return [
            [np.unique([cut_lower[j, i], middle[j, i], cut_upper[j, i]]) for i in range(len(names))]
            for j in range(len(cut_lower))
        ]

    def closed_form(self, request: CountRequest) -> int:
        return (request.steps + 1) * 3 ** len(request.names) + 1


def test_a_new_method_is_one_class_the_plan_and_the_count_use():
    three = {**PARAMETERS, "x3": Triangular(-1.0, 0.0, 2.0)}
    for levels in (1, 3):
        built = plan(three, ThreePoint(), levels)
        assert built.method == "three-point" and isinstance(built.scheme, Method)
        assert run_count(three, ThreePoint(), levels) == len(built)
        assert len(built) <= ThreePoint().closed_form(
            CountRequest(tuple(three), [], (), levels, levels)
        )
    outputs = built.evaluate(lambda c: {"z": c["x1"] * c["x2"] - c["x3"] ** 2})
    result = built.retransform(outputs)["z"]
    # at mu = 0 the points hold x1 x2 = 3 * 2 only with x3 in {-1, 0.5, 2} (the cut's
    # bounds and midpoint, not the modal 0): 6 - 0.5^2, by hand; the core is the modal point
    assert result.upper[0] == 5.75 and result.lower[-1] == result.upper[-1] == 2.0


def test_the_study_file_has_a_key_for_every_declared_option():
    keys = set(StudySection.model_fields)
    for cls in METHODS.values():
        assert {declared.name for declared in cls.options()} <= keys
    assert set(StudySection.model_fields["method"].annotation.__args__) == set(METHODS)


@pytest.mark.parametrize("name", list(METHODS))
def test_a_study_checks_a_method_by_validation_runs_unless_it_certifies_itself(name):
    from fuzzymbs.study.study import Study

    study = Study("product", PARAMETERS, method=name, levels=2)
    if METHODS[name].supports_validation:
        assert study.validation_count() == 12 * len(PARAMETERS)  # the default's floor
    else:
        assert study.validation_count() == 0


def test_the_count_refuses_what_the_plan_refuses():
    # the count checks the method's options as the plan does: the adaptive method's default
    # search grid (20,000 points per cut box) cannot hold 3^10 points
    ten = {f"x{i}": Triangular(i, i + 1.0, i + 2.0) for i in range(10)}
    for make in (lambda: plan(ten, "adaptive", 2), lambda: run_count(ten, "adaptive", 2)):
        with pytest.raises(InvalidPlanError, match=r"search_points must be an int >= 3\^n = 59049"):
            make()
    assert run_count(ten, method_named("adaptive", search_points=3**10), 2) == 2000
