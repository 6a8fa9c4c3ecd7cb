"""Triangular solves in numpy, so that the identification path needs no ``scipy.linalg``.

``numpy.linalg.solve`` factorises with partial pivoting; on an upper-triangular matrix no
row is exchanged (every entry below the diagonal is zero), so the factorisation is the
matrix itself and the solve is back substitution.  A lower-triangular system is solved
as the upper-triangular one of the reversed rows and columns.
"""

from __future__ import annotations

import numpy as np

__all__ = ["solve_lower", "solve_upper"]


def solve_upper(R: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``R^-1 B`` for an upper-triangular, non-singular ``R`` (n, n); ``B`` (n,) or (n, k)."""
    return np.linalg.solve(R, B)


def solve_lower(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``L^-1 B`` for a lower-triangular, non-singular ``L`` (n, n); ``B`` (n,) or (n, k)."""
    return np.linalg.solve(L[::-1, ::-1], B[::-1])[::-1]
