"""Mass, damping and stiffness from proper complex modes (thesis 3.3.1, eqs. 3.44-3.45).

For proper complex modes ``psi`` and poles ``lambda`` the truncated second-order matrices
in the reduced coordinates are given exactly by sums over the ``2 n`` modes (3.44):
``M_T = (psi Lambda psi^T)^-1``, ``C_T = -M_T psi Lambda^2 psi^T M_T``,
``K_T = -(psi Lambda^-1 psi^T)^-1``; a physical model needs them positive definite (3.45).
:func:`transformation` returns them as a :class:`ReducedMatrices` record.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

__all__ = ["ReducedMatrices", "damping_advice", "transformation"]


@dataclass(frozen=True, eq=False)
class ReducedMatrices:
    """The matrices (3.44) of the reduced coordinates and their definiteness (3.45).

    Attributes
    ----------
    M_T, C_T, K_T : ndarray, shape (n, n)
        Mass, damping and stiffness in the reduced coordinates ``q_T``.
    mass_eigenvalues, stiffness_eigenvalues : ndarray, shape (n,)
        Eigenvalues of ``M_T`` and ``K_T``.
    damping_eigenvalues : ndarray, shape (n,)
        Eigenvalues of ``C_T`` relative to ``M_T`` (rad/s).
    positive_definite : dict of str to bool
        ``{"mass": ..., "stiffness": ..., "damping": ...}`` (3.45; damping semi-definite).
    """

    M_T: np.ndarray
    C_T: np.ndarray
    K_T: np.ndarray
    mass_eigenvalues: np.ndarray
    stiffness_eigenvalues: np.ndarray
    damping_eigenvalues: np.ndarray
    positive_definite: dict


def transformation(psi: np.ndarray, lam: np.ndarray) -> ReducedMatrices:
    """Exact transformation (3.44) of proper complex modes to ``M_T, C_T, K_T``; (3.45).

    ``M_T = (psi Lambda psi^T)^-1``, ``C_T = -M_T (psi Lambda^2 psi^T) M_T`` and
    ``K_T = -(psi Lambda^-1 psi^T)^-1``, sums over the ``2 n`` modes.

    Parameters
    ----------
    psi : ndarray, shape (n, n), complex
        Proper complex modes (one column per upper half-plane pole).
    lam : ndarray, shape (n,), complex
        The poles (rad/s).

    Returns
    -------
    ReducedMatrices
        ``M_T``, ``C_T``, ``K_T``, their eigenvalues and ``positive_definite``.

    Raises
    ------
    ValueError
        When the identified mass or stiffness is not positive definite (3.45).

    Warns
    -----
    RuntimeWarning
        When the identified damping is not positive semi-definite (:func:`damping_advice`).
    """
    def ssum(d):
        X = 2.0 * ((psi * d) @ psi.T).real
        return 0.5 * (X + X.T)

    Minv, S2, Kinv = ssum(lam), ssum(lam**2), -ssum(1.0 / lam)
    em, ek = np.linalg.eigvalsh(Minv), np.linalg.eigvalsh(Kinv)
    pd = {"mass": bool(em.min() > 0), "stiffness": bool(ek.min() > 0)}
    if not pd["mass"]:
        raise ValueError(
            f"cm: the identified mass (psi Lambda psi^T)^-1 (3.44) is not positive definite "
            f"(3.45; eigenvalues of its inverse {np.array2string(em, precision=3)}): the "
            f"complex modes are badly identified, badly scaled or coupled to modes outside "
            f"the model")
    if not pd["stiffness"]:
        raise ValueError(
            f"cm: the identified stiffness -(psi Lambda^-1 psi^T)^-1 (3.44) is not positive "
            f"definite (3.45; eigenvalues of its inverse {np.array2string(ek, precision=3)})")
    MT = np.linalg.inv(Minv)
    MT = 0.5 * (MT + MT.T)
    KT = np.linalg.inv(Kinv)
    KT = 0.5 * (KT + KT.T)
    CT = -MT @ S2 @ MT
    CT = 0.5 * (CT + CT.T)
    ec = sla.eigh(CT, MT, eigvals_only=True)       # damping relative to mass: rad/s
    pd["damping"] = bool(ec.min() >= -1e-12 * max(np.abs(ec).max(), 1e-300))
    if not pd["damping"]:
        warnings.warn(damping_advice(ec), RuntimeWarning, stacklevel=5)
    return ReducedMatrices(MT, CT, KT, np.linalg.eigvalsh(MT), np.linalg.eigvalsh(KT), ec, pd)


def damping_advice(ec: np.ndarray) -> str:
    """The non-positive damping warning (3.45): what was found and what to do about it.

    Parameters
    ----------
    ec : ndarray, shape (n,)
        Eigenvalues of the identified damping relative to the mass (rad/s).

    Returns
    -------
    str
    """
    rel = ec.min() / max(np.abs(ec).max(), 1e-300)
    cause = ("small: typically noise on a lightly damped or out-of-band mode; identify with "
             "more lines or less noise around it" if rel > -1e-2 else
             "large: look for a pole that is not a structural mode (cm.in_band, "
             "cm.singular_value_ratios(); leave it out with modes=...) or a wrong collocated "
             "pair (same point, same direction, same sign)")
    return (f"normal_modes: the identified damping matrix is not positive semi-definite "
            f"(3.45; min eigenvalue {ec.min():.3g} rad/s against max {ec.max():.3g}, "
            f"{rel:.1e} of it). The model keeps the identified stable poles and can be used "
            f"as is, but it is not passive along one direction, which matters for passivity "
            f"arguments and bounds on Gamma (5.2.2). This one is {cause}; "
            f"nm.properness.damping_eigenvalues has the spectrum.")
