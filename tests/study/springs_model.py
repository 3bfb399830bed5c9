"""Two springs in series: a model for the identification-file tests (tests/study)."""

import numpy as np


def make_springs(scale: float = 1.0):
    """Batched model: series stiffness k1 k2 / (k1 + k2) and ratio k1 / k2 (times ``scale``)."""

    def springs(p):
        k1, k2 = np.asarray(p["k1"], float), np.asarray(p["k2"], float)
        return {"series": scale * k1 * k2 / (k1 + k2), "ratio": k1 / k2}

    return springs
