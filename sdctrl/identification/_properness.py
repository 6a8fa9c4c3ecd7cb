"""Properness of complex modes and its optimal correction (thesis 3.3.2, eqs. 3.40-3.54).

Complex modes of a second-order system with ``n`` degrees of freedom are *proper*:
``psi psi^T = 0`` summed over the ``2 n`` modes (3.40).  Identified modes are not, exactly;
the closest proper modes (3.51) are ``psi~ = (I - delta^2)^-1 (psi - delta conj(psi))``
with the small real root ``delta`` of the Riccati equation (3.52), whose spectral radius
must stay below 1 (minimum condition 3.54).  :func:`proper_modes` finds it by Newton's
method from ``delta = 0`` and returns the corrected modes with a :class:`RiccatiCorrection`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

__all__ = ["DELTA_MAX", "DELTA_WARN", "RiccatiCorrection", "proper_modes"]

#: above this spectral radius of ``delta`` the correction is reported as large (warning)
DELTA_WARN = 0.5
#: at or above this spectral radius ``I - delta^2`` of (3.51) is near singular: refused
DELTA_MAX = 0.9


@dataclass(frozen=True, eq=False)
class RiccatiCorrection:
    """The properness correction (3.51)-(3.52) of one set of complex modes.

    Attributes
    ----------
    delta : ndarray, shape (n, n)
        The small real symmetric root of the Riccati equation (3.52).
    delta_eigenvalues : ndarray, shape (n,)
        Its eigenvalues (sorted, real).
    delta_radius : float
        Their largest modulus; must be well below 1 (3.54).
    riccati_residual : float
        Relative residual of (3.52) at ``delta``.
    newton_iterations : int
        Newton steps taken from ``delta = 0``.
    properness_before, properness_after : float
        ``||psi psi^T|| / ||psi psi^H||`` (sums over the ``2 n`` modes, 3.40) before and
        after the correction.
    """

    delta: np.ndarray
    delta_eigenvalues: np.ndarray
    delta_radius: float
    riccati_residual: float
    newton_iterations: int
    properness_before: float
    properness_after: float


def _newton(A0, G, scale, tol, maxiter):
    """Newton's method on (3.52) from ``delta = 0``: ``delta``, relative residual, steps."""
    n = A0.shape[0]
    delta = np.zeros((n, n))
    res = np.linalg.norm(A0) / scale
    it = 0
    while res > tol and it < maxiter:
        F = A0 - delta @ G - G @ delta + delta @ A0 @ delta
        X = sla.solve_sylvester(G - delta @ A0, G - A0 @ delta, F)
        delta = delta + 0.5 * (X + X.T)
        it += 1
        F = A0 - delta @ G - G @ delta + delta @ A0 @ delta
        new = np.linalg.norm(F) / scale
        if not np.isfinite(new):
            break
        if it > 5 and new > 0.5 * res and new > 1e3 * tol:
            res = new
            break                                      # stagnation: not converging
        res = new
    return delta, res, it


def proper_modes(psi: np.ndarray, tol: float = 1e-13, maxiter: int = 50):
    """Closest proper complex modes, eq. (3.51), by the small real root of (3.52).

    With ``A0 = psi psi^T`` and ``G = conj(psi) psi^T`` summed over the ``2 n`` modes
    (both real symmetric), the Riccati equation (3.52) reads
    ``A0 - delta G - G delta + delta A0 delta = 0``.  Newton's method from
    ``delta = 0`` solves, at each step, the Sylvester equation
    ``(G - delta A0) X + X (G - A0 delta) = F(delta)`` and converges to the root that
    tends to 0 with the properness error (a generic stable-subspace Riccati solver may
    return a large root, useless here).  The corrected modes are
    ``psi~ = (I - delta^2)^-1 (psi - delta conj(psi))``.

    The thesis proposes the real positive-definite root.  In practice the small root is
    real and symmetric but generally *indefinite* (eigenvalues of both signs, of the order
    of the properness error); it is the anti-stabilising solution of the CARE
    ``G X + X G - X A0 X - A0 = 0`` (Hamiltonian ``[[G, -A0], [A0, -G]]``), while the
    stabilising one returned by standard solvers has ``|eig| >> 1`` and violates the
    minimum condition (3.54), ``|eig(delta)| < 1``.

    Parameters
    ----------
    psi : ndarray, shape (n, n)
        Complex modes (upper-half-plane poles) in the reduced coordinates.
    tol : float
        Relative tolerance on the Riccati residual.
    maxiter : int
        Maximum Newton iterations.

    Returns
    -------
    psi_p : ndarray, shape (n, n)
        Proper complex modes.
    correction : RiccatiCorrection
        ``delta``, its spectrum and radius, the residual, the Newton steps and the
        properness before and after.

    Raises
    ------
    ValueError
        No small real root from ``delta = 0`` (``|eig(delta)| >= 0.9`` or no convergence).
    """
    n = psi.shape[0]
    A0 = 2.0 * (psi @ psi.T).real
    G = 2.0 * (psi @ psi.conj().T).real
    A0, G = 0.5 * (A0 + A0.T), 0.5 * (G + G.T)
    scale = np.linalg.norm(G)
    before = float(np.linalg.norm(A0) / scale)
    delta, res, it = _newton(A0, G, scale, tol, maxiter)
    ev = np.linalg.eigvals(delta)
    radius = float(np.abs(ev).max()) if n else 0.0
    ev = np.sort(ev.real) if np.allclose(ev.imag, 0) else ev       # delta is symmetric
    if not np.isfinite(res) or res > max(1e3 * tol, 1e-8) or radius >= DELTA_MAX:
        raise ValueError(
            f"cm: the Riccati equation (3.52) has no small real root from delta = 0 "
            f"(residual {res:.2e}, max |eig(delta)| = {radius:.3g} after {it} Newton steps); "
            f"the identified complex modes are too far from proper (properness error "
            f"{before:.2e}) or badly scaled")
    if radius > DELTA_WARN:
        warnings.warn(f"normal_modes: large properness correction, max |eig(delta)| = "
                      f"{radius:.3g} (should be well below 1, 3.54)", RuntimeWarning,
                      stacklevel=4)
    psi_p = np.linalg.solve(np.eye(n) - delta @ delta, psi - delta @ psi.conj())
    after = float(np.linalg.norm(2.0 * (psi_p @ psi_p.T).real)
                  / np.linalg.norm(2.0 * (psi_p @ psi_p.conj().T).real))
    return psi_p, RiccatiCorrection(delta, ev, radius, float(res), it, before, after)
