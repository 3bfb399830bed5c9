"""Product model z = x1 * x2: the simplest closed-form check of the transformation method."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


class ProductModel:
    """Batched model ``z = x1 * x2``.

    Exact alpha-cuts for positive triangular inputs are known in closed form
    (Hanss 2005, ch. 5; THEORY.md section 1 oracle), so the reduced
    transformation method must reproduce them exactly: the product is monotonic
    in each factor on the positive quadrant.

    Outputs
    -------
    z : (B,) ndarray
        Product of the two inputs (unit: product of the inputs' units).
    """

    coords: dict[str, np.ndarray] = {}  # noqa: RUF012 - scalar output, no trailing axes

    def __call__(self, samples: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``{"z": x1 * x2}`` for samples ``{"x1": (B,), "x2": (B,)}``."""
        x1 = np.asarray(samples["x1"], dtype=float)
        x2 = np.asarray(samples["x2"], dtype=float)
        return {"z": x1 * x2}


def make_product() -> ProductModel:
    """Factory registered as ``"product"``; takes no options."""
    return ProductModel()
