"""The relative measurement noise of the simulated tests (one definition for every member of
the family, the scalable structure and the demo's retest)."""

from __future__ import annotations

import numpy as np

__all__ = ["relative_noise"]


def relative_noise(H: np.ndarray, noise: float, seed) -> np.ndarray:
    """``H (1 + noise e)``, ``e`` complex standard normal (``E|e|^2 = 1``) drawn from ``seed``.

    Parameters
    ----------
    H : ndarray
        Exact FRF values (not modified).
    noise : float
        Relative noise level; 0 returns ``H`` itself.
    seed : int or None
        Seed of :func:`numpy.random.default_rng`.

    Returns
    -------
    ndarray
    """
    if noise <= 0:
        return H
    rng = np.random.default_rng(seed)
    e = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return H * (1 + noise * e)
