"""Variance of the identified residues from the measured coherence (thesis 3.4.2).

The coherence ``kappa`` of an unbiased FRF estimate gives a diagonal covariance of the
measured points, ``sigma_H^2 = |H|^2 (1 - kappa)`` (3.59).  For fixed poles the residues
are linear in the data, ``R = Phi^+ H`` (3.17), so their covariance is
``Sigma_R = Phi^+ Sigma_M Phi^+^T`` (3.60): the direct part of (3.58).  The indirect part,
through errors of the poles, is not included (the thesis evaluates it case by case).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.validate import QUANTITY_POWER
from sdctrl.identification._residues import LSQ, basis

__all__ = ["residue_std"]


def residue_std(cm, frf, n_averages: int = 1) -> np.ndarray:
    """Standard deviation of the residues of ``cm`` from the coherence of ``frf`` (3.59)-(3.60).

    Parameters
    ----------
    cm : ComplexModeModel
        Identified model (its band and poles define the basis ``Phi``).
    frf : FRF
        Measured FRF with ``coherence`` (same sensors and actuators as ``cm``).
    n_averages : int
        Number of averages of the FRF estimate; the point variance (3.59) is divided by it.

    Returns
    -------
    ndarray, shape (n, ns, na)
        Standard deviation of each complex residue ``R_j`` (real and imaginary parts
        together, ``sqrt(var Re + var Im)``).
    """
    from sdctrl.data._frf import FRF

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    if frf.coherence is None:
        raise ValueError("frf must carry a coherence to estimate the residue variance (3.59)")
    if frf.H.shape[1:] != (cm.ns, cm.na):
        raise ValueError(f"frf must have {cm.ns} sensors x {cm.na} actuators like the model, "
                         f"got {frf.H.shape[1:]}")
    if isinstance(n_averages, bool) or not isinstance(n_averages, int | np.integer) \
            or n_averages < 1:
        raise ValueError(f"n_averages must be a positive integer, got {n_averages!r}")
    data = frf.band(*cm.band) if cm.band is not None else frf
    nf = data.freq.size
    s = 2j * np.pi * data.freq
    k = QUANTITY_POWER[data.quantity]
    fit = cm.search                               # how the model was fitted, when known
    model = (None if fit is None else fit.model) or "complex"
    asym = (False, False) if fit is not None and fit.asymptotic is False else (True, True)
    Phi = basis(cm.poles, s, k, model, asym)
    lsq = LSQ(Phi)
    # pseudo-inverse rows of the real stacked problem: P = diag(1/scale) R^-1 Q^T
    from scipy.linalg import solve_triangular

    P = solve_triangular(lsq.Rr, lsq.Q.T) / lsq.scale[:, None]          # (p, 2nf)
    var = np.abs(data.H) ** 2 * (1.0 - data.coherence) / n_averages    # (nf, ns, na)
    var = var.reshape(nf, -1) / 2.0                                     # per real/imag part
    W = np.vstack([var, var])                                           # (2nf, m)
    vc = (P**2) @ W                                                     # (p, m)
    n = cm.n
    if model == "complex":
        v = vc[0:2 * n:2] + vc[1:2 * n:2]
    else:
        v = vc[:n] / np.abs(cm.poles - cm.poles.conj())[:, None] ** 2
    return np.sqrt(v).reshape(n, cm.ns, cm.na)
