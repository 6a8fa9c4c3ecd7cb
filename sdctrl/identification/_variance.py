"""Variance of the identified residues (thesis 3.4.2), both parts of (3.58).

For fixed poles the residues are linear in the data, ``R = Phi^+ H`` (3.17), so their
covariance is ``Sigma_R = Phi^+ Sigma_M Phi^+^T`` (3.60), the direct part of (3.58), with the
point variance ``|H|^2 (1 - kappa)`` (3.59) when the FRF carries a coherence ``kappa``, else
estimated from the fit residual.  The part through the poles (their errors change the basis
``Phi``) follows from the poles' covariance (3.56), see
:mod:`sdctrl.identification._pole_statistics`.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.threads import single_thread
from sdctrl.identification._pole_statistics import fit_statistics, part_std

__all__ = ["model_statistics", "residue_std", "statistics_or_none"]


def recorded_divisor(data) -> int:
    """``n_d - 1`` for an FRF that records its ``n_d >= 2`` averages (the coherence from the
    same records overstates the point variance 3.59 that many times), else 1."""
    n = getattr(data, "averages", None)
    return n - 1 if n is not None and n >= 2 else 1


def model_statistics(cm, data, n_averages: int | None = None):
    """:class:`FitStatistics` of ``cm`` fitted to ``data`` (the band's lines), with the
    options of its fit (poles held fixed when they were given with ``optimizer="none"``).

    Parameters
    ----------
    cm : ComplexModeModel
        Identified model.
    data : FRF
        The lines of its band.
    n_averages : int, optional
        Divisor of the point variance (3.59); default from the averages ``data`` records
        (:func:`recorded_divisor`).

    Returns
    -------
    FitStatistics or None
    """
    if n_averages is None:
        n_averages = recorded_divisor(data)
    fit = cm.search                               # how the model was fitted, when known
    model = (None if fit is None else fit.model) or "complex"
    asym = (False, False) if fit is not None and fit.asymptotic is False else (True, True)
    return fit_statistics(cm, data, model, asym, n_averages,
                          poles_fixed=fit is not None and fit.optimizer == "none")


def statistics_or_none(cm, data):
    """:func:`model_statistics` of a fit, None when they cannot be evaluated in double
    precision (data at the edge of the float range) rather than NaN or an error.

    Parameters
    ----------
    cm : ComplexModeModel
        The fit.
    data : FRF
        The lines of its band.

    Returns
    -------
    FitStatistics or None
    """
    with np.errstate(all="ignore"):
        try:
            stats = model_statistics(cm, data)
        except (np.linalg.LinAlgError, ValueError):
            return None
    if stats is None or not all(np.all(np.isfinite(a)) for a in
                                (stats.S, stats.A_inv, stats.M, stats.K, stats.V)):
        return None
    return stats


def residue_std(cm, frf=None, n_averages: int | None = None,
                direct_only: bool = False) -> np.ndarray:
    """Standard deviation of the residues of ``cm`` (3.58)-(3.60).

    Parameters
    ----------
    cm : ComplexModeModel
        Identified model (its band and poles define the basis ``Phi``).
    frf : FRF, optional
        Measured FRF (same sensors and actuators as ``cm``), with or without coherence;
        default the statistics stored on ``cm`` by :func:`~sdctrl.identify`.
    n_averages : int, optional
        Divisor of the point variance (3.59) of ``frf``; default ``n_d - 1`` when ``frf``
        records its ``n_d >= 2`` averages (``frf.averages``), else 1.
    direct_only : bool
        Only the direct part of (3.58).

    Returns
    -------
    ndarray, shape (n, ns, na)
        Standard deviation of each complex residue ``R_j`` (real and imaginary parts
        together, ``sqrt(var Re + var Im)``); NaN when the data do not determine them.
    """
    from sdctrl.data._frf import FRF

    if n_averages is not None and (isinstance(n_averages, bool) or
                                   not isinstance(n_averages, int | np.integer) or n_averages < 1):
        raise ValueError(f"n_averages must be a positive integer, got {n_averages!r}")
    if frf is None:
        stats = cm.statistics
    else:
        if not isinstance(frf, FRF):
            raise TypeError(f"frf must be an sdctrl.FRF or None, got {type(frf).__name__}")
        if frf.H.shape[1:] != (cm.ns, cm.na):
            raise ValueError(f"frf must have {cm.ns} sensors x {cm.na} actuators like the "
                             f"model, got {frf.H.shape[1:]}")
        data = frf.band(*cm.band) if cm.band is not None else frf
        with single_thread():                     # small dense kernels, as identify
            stats = model_statistics(cm, data, n_averages)
    if stats is None:
        return np.full(cm.residues.shape, np.nan)
    parts = part_std(stats, cm.poles, np.shape(cm.residues), direct_only)[1]
    return np.hypot(parts.real, parts.imag)
