"""The transformation methods by name: the one list of the public method names.

A new method is a module of this package (a :class:`~fuzzymbs.fuzzy.methods.base.Method`
subclass) and one entry below.
"""

from __future__ import annotations

from typing import Any

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.methods.adaptive import Adaptive
from fuzzymbs.fuzzy.methods.base import Method
from fuzzymbs.fuzzy.methods.extended import Extended
from fuzzymbs.fuzzy.methods.general import General
from fuzzymbs.fuzzy.methods.grid import Grid
from fuzzymbs.fuzzy.methods.reduced import Reduced
from fuzzymbs.fuzzy.methods.sparse import Sparse

__all__ = ["METHODS", "method_named", "option_users"]

#: every method by its public name, in the order the documentation lists them
METHODS: dict[str, type[Method]] = {
    cls.name: cls for cls in (General, Reduced, Extended, Grid, Sparse, Adaptive)
}


def option_users(option: str) -> list[str]:
    """The names of the methods that declare ``option``."""
    return [name for name, cls in METHODS.items() if cls.declares(option)]


def method_named(name: Any, **options: Any) -> Method:
    """The method ``name`` with ``options`` (those given as None are not given).

    Parameters
    ----------
    name : str or Method
        A public method name (:data:`METHODS`), or a method object (returned as is; then
        no options may be given).
    **options
        The method's options by name (None or an empty list: not given).

    Raises
    ------
    InvalidPlanError
        An unknown method (naming the valid ones), an option the method does not declare
        (naming the methods that do), or an invalid option value (naming the option).
    """
    given = {
        key: value
        for key, value in options.items()
        if value is not None and not (isinstance(value, list | tuple) and not value)
    }
    if isinstance(name, Method):
        if given:
            raise InvalidPlanError(
                f"options {sorted(given)} given beside the method object {name!r}: give them "
                "to the method object instead"
            )
        return name
    if not isinstance(name, str) or name not in METHODS:
        raise InvalidPlanError(f"unknown method {name!r}; valid methods: {list(METHODS)}")
    cls = METHODS[name]
    misplaced = [key for key in given if not cls.declares(key)]
    if misplaced:
        users = [user for user in METHODS if any(user in option_users(k) for k in misplaced)]
        text = ", ".join(f"{key}={given[key]!r}" for key in misplaced)
        verb = "is" if len(misplaced) == 1 else "are"
        where = " or ".join(repr(user) for user in users)
        raise InvalidPlanError(f"{text} {verb} only used by method={where}, not {name!r}")
    return cls(**given)
