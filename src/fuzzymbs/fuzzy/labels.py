"""Labels of an output's own axes when a fuzzy result becomes an xarray Dataset.

Outputs carry a leading sample axis and trailing axes of their own (time, mesh
position, node, ...). Fuzzy results and influence measures keep those trailing
axes; :class:`DatasetExport` names them and attaches their coordinates the same
way for both.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import UnsupportedOperationError

if TYPE_CHECKING:  # pragma: no cover
    import xarray

__all__ = ["DatasetExport", "DatasetParts", "checked_coords", "trailing_dims"]


def trailing_dims(name: str, shape: tuple[int, ...], dims: Sequence[str] | None) -> list[str]:
    """Names of an output's trailing axes.

    Parameters
    ----------
    name : str
        Output name; the default names are ``{name}_dim0``, ``{name}_dim1``, ...
    shape : tuple of int
        Shape of the trailing axes.
    dims : sequence of str, optional
        Names given by the caller, one per trailing axis.

    Raises
    ------
    UnsupportedOperationError
        If ``dims`` does not name every trailing axis exactly once.
    """
    if dims is None:
        return [f"{name}_dim{k}" for k in range(len(shape))]
    dims = list(dims)
    if len(dims) != len(shape):
        raise UnsupportedOperationError(
            f"dims {dims} must name each of the {len(shape)} trailing axes of shape {shape}"
        )
    return dims


def checked_coords(
    coords: Mapping[str, ArrayLike] | None, dims: Sequence[str], shape: tuple[int, ...]
) -> dict[str, NDArray]:
    """Coordinate arrays for trailing axes, checked against the axes' names and lengths.

    Parameters
    ----------
    coords : mapping of str to array_like, optional
        ``{dim: values}`` for some or all of ``dims``.
    dims : sequence of str
        Names of the trailing axes.
    shape : tuple of int
        Their lengths.

    Raises
    ------
    UnsupportedOperationError
        For a coordinate that names no axis or does not match the axis length.
    """
    result: dict[str, NDArray] = {}
    for key, values in (coords or {}).items():
        if key not in dims:
            raise UnsupportedOperationError(f"coordinate {key!r} is not one of the dims {dims}")
        array = np.asarray(values)
        size = shape[list(dims).index(key)]
        if array.shape != (size,):
            raise UnsupportedOperationError(
                f"coordinate {key!r} must have shape ({size},), got {array.shape}"
            )
        result[key] = array
    return result


class DatasetParts(NamedTuple):
    """What a result contributes to its Dataset: ``variables``, ``coords`` and ``attrs``."""

    variables: dict[str, Any]
    coords: dict[str, Any]
    attrs: dict[str, Any]


class DatasetExport(ABC):
    """Base of results over an output's trailing axes that convert to an xarray Dataset.

    A subclass gives the shape of those axes and its variables
    (:meth:`dataset_parts`); :meth:`to_xarray` names the axes and checks and
    attaches their coordinates.
    """

    @property
    @abstractmethod
    def shape(self) -> tuple[int, ...]:
        """Shape of the output's own (trailing) axes."""

    @abstractmethod
    def dataset_parts(self, name: str, dims: list[str]) -> DatasetParts:
        """Variables (over ``dims`` and axes of the result's own), coordinates, attributes."""

    def to_xarray(
        self,
        name: str = "output",
        dims: Sequence[str] | None = None,
        coords: Mapping[str, ArrayLike] | None = None,
    ) -> xarray.Dataset:
        """Dataset of this result; its variables are listed in the class docstring.

        Parameters
        ----------
        name : str
            Output name, the prefix of the variable names.
        dims : sequence of str, optional
            Names of the output's trailing axes (default ``{name}_dim0``, ...).
        coords : mapping, optional
            Coordinate values for those dims (e.g. ``{"time": t}``).

        Raises
        ------
        UnsupportedOperationError
            For ``dims`` or ``coords`` that do not match the trailing axes.
        """
        import xarray

        dims = trailing_dims(name, self.shape, dims)
        parts = self.dataset_parts(name, dims)
        coordinates = dict(parts.coords)
        coordinates.update(checked_coords(coords, dims, self.shape))
        return xarray.Dataset(parts.variables, coords=coordinates, attrs=parts.attrs)
