"""How drawn and measured numbers are rounded before a sample stores them: 6 decimals unless a
field says otherwise (poses 7, paths 5), so metadata is short and the same on every machine."""

from __future__ import annotations

import numpy as np

DECIMALS = 6


def rounded(values, digits: int = DECIMALS) -> list:
    """An array (any shape) as nested lists of floats rounded to ``digits`` decimals."""
    return np.round(np.asarray(values, float), digits).tolist()


def uniform(rng: np.random.Generator, bounds, digits: int = DECIMALS) -> float:
    """One draw from U(low, high) of ``bounds``, rounded to ``digits`` decimals."""
    return round(float(rng.uniform(*bounds)), digits)
