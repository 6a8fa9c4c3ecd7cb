"""Bounds from the physics of a normal-mode model (thesis section 5.2.2).

The damping couplings ``Gamma`` positive semi-definite (:func:`psd_gamma_bound`), the
stiffness couplings within the modal density (:func:`modal_density_bound`), and both as
the default bounds of :func:`~sdctrl.robust._uncertainty.uncertain`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["default_bounds", "modal_density_bound", "psd_gamma_bound"]


def psd_gamma_bound(Gamma, fraction: float = 1.0) -> np.ndarray:
    """Off-diagonal bounds keeping ``Gamma`` positive semi-definite (section 5.2.2).

    For a 2x2 principal minor, ``Gamma_ij^2 <= Gamma_ii Gamma_jj``.

    Parameters
    ----------
    Gamma : array_like (n, n)
        Modal damping matrix.
    fraction : float
        Fraction of the positive definiteness bound to use.

    Returns
    -------
    ndarray (n, n)
        ``fraction * sqrt(g_ii g_jj)`` off the diagonal, 0 on it.
    """
    G = np.asarray(Gamma, float)
    g = np.sqrt(np.clip(np.diag(G), 0, None))
    out = fraction * np.outer(g, g)
    np.fill_diagonal(out, 0.0)
    return out


def modal_density_bound(Omega, fraction: float = 1.0) -> np.ndarray:
    """Modal-density bound ``|Omega_ii - Omega_jj|`` on stiffness couplings (section 5.2.2).

    Parameters
    ----------
    Omega : array_like (n, n)
        Modal stiffness matrix.
    fraction : float
        Fraction of the bound to use.

    Returns
    -------
    ndarray (n, n)
    """
    d = np.diag(np.asarray(Omega, float))
    out = fraction * np.abs(d[:, None] - d[None, :])
    np.fill_diagonal(out, 0.0)
    return out


def default_bounds(model, gamma_fraction: float = 0.5, omega_fraction: float = 0.1) -> dict:
    """Sensible default bounds from the physical constraints of section 5.2.

    Parameters
    ----------
    model : NormalModeModel
        Nominal model.
    gamma_fraction : float
        Fraction of the positive definiteness bound on ``Gamma`` couplings.
    omega_fraction : float
        Fraction of the modal-density bound on ``Omega`` couplings.

    Returns
    -------
    dict
        ``{"dGamma": ..., "dOmega": ...}`` usable as ``uncertain(model, **bounds)``.
    """
    return {"dGamma": psd_gamma_bound(model.Gamma, gamma_fraction),
            "dOmega": modal_density_bound(model.Omega, omega_fraction)}
