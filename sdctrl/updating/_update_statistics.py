"""Standard deviations of updated FE parameters (Cramer-Rao bound of the logLS fit, 3.12).

Near the optimum the logLS residual ``e(p) = log|H(p)| - log|H_m|`` is linear in the
parameters, ``e ~ e_0 + J dp`` with ``J = d log|H| / dp`` (one row per line, sensor and
actuator).  With independent errors of variance ``v_k`` on the measured ``log|H|`` the
least-squares estimate has the covariance

``Cov(p) = (J^T J)^-1 J^T diag(v) J (J^T J)^-1``

(the Cramer-Rao bound when ``v`` is uniform).  The point variance of ``log|H|`` is
``(1 - coherence) / 2`` per average (3.59: the relative variance of ``H`` is
``1 - coherence``, half of it on the log-magnitude); without a coherence it is the mean
squared residual of the fit with its degrees of freedom, ``|e|^2 / (N - npar)`` (model
error included), or an error level given by the caller.  The same formula before any
update, at the nominal model, predicts how well a test will determine each parameter
(:func:`~sdctrl.identifiability`).

After an update the noise is not all: the FE model, its reduction or the data (itself a
reduction of some structure) may be slightly wrong, and that bias the noise's covariance
does not see.  So the fitted standard deviation is the larger of the noise's and the
sensors' scatter (:mod:`sdctrl._lib.sensor_scatter`: the leverage-corrected leave-one-sensor-out
covariance, the same rule as a diagnosis's ``Effect.std``).  Measured on the family of test
structures at 1% noise (seeds 1-2): the trusses' test data are a modal reduction of their
FE model (logLS 3.5e-4 from it at the true parameters, noise-free), the links come out
1.3e-3 off, 60 noise standard deviations and 1.1 of the scatter's; on the ladder, the plate,
the cluster and a held-out tower, whose data are their FE model's, both agree (0.1-1.5
standard deviations).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.sensor_scatter import channel_groups, scatter_covariance
from sdctrl.data._coherence import measured_coherence

__all__ = ["fitted_std", "log_jacobian", "log_point_variance", "parameter_covariance",
           "std_and_correlation"]


def log_point_variance(frf, shape, n_averages: int = 1, residual=None, npar: int = 0,
                       level: float | None = None):
    """Variance of each measured ``log|H|`` point, shape ``shape`` (nf, ns, na).

    Parameters
    ----------
    frf : FRF or None
        The measured lines (its coherence, when it measures the noise, gives the variance:
        :func:`~sdctrl.data._coherence.measured_coherence`).
    shape : tuple
        Shape of the measured ``log|H|``.
    n_averages : int
        Averages behind the coherence.
    residual : ndarray, optional
        logLS residual at the optimum (used without coherence and ``level``).
    npar : int
        Number of fitted parameters (degrees of freedom of the residual).
    level : float, optional
        A known mean squared log-magnitude error (used without coherence).

    Returns
    -------
    ndarray, shape ``shape``
    """
    coh = None if frf is None else measured_coherence(frf)
    if coh is not None:
        coh = coh if coh.ndim == 3 else coh[:, :, None]
        return np.broadcast_to((1.0 - coh) / (2.0 * n_averages), shape).copy()
    if level is None:
        r = np.asarray(residual).ravel()
        level = float(r @ r) / max(r.size - npar, 1)
    return np.full(shape, float(level))


def parameter_covariance(J, var) -> np.ndarray:
    """Sandwich covariance of least-squares parameters (module notes).

    Parameters
    ----------
    J : ndarray, shape (N, npar)
        Jacobian of ``log|H|`` with respect to the parameters.
    var : ndarray, shape (N,)
        Variance of each measured point.

    Returns
    -------
    ndarray, shape (npar, npar)
        NaN where ``J^T J`` is singular (a parameter without effect on the test).
    """
    A = J.T @ J
    n = A.shape[0]
    d = np.sqrt(np.maximum(np.diag(A), 0.0))
    if np.any(d == 0) or not np.all(np.isfinite(A)):
        return np.full((n, n), np.nan)
    An = A / np.outer(d, d)                                 # scaled: condition of the test
    if np.linalg.cond(An) > 1e14:
        return np.full((n, n), np.nan)
    Ai = np.linalg.inv(An) / np.outer(d, d)
    B = J.T @ (J * var[:, None])
    return Ai @ B @ Ai


def std_and_correlation(names, cov):
    """``(std dict, correlation matrix)`` of the estimates from their covariance.

    Parameters
    ----------
    names : sequence of str
        Parameter names.
    cov : ndarray, shape (npar, npar)
        Covariance.

    Returns
    -------
    std : dict
        Name -> standard deviation (NaN when undetermined).
    correlation : ndarray, shape (npar, npar)
    """
    s = np.sqrt(np.maximum(np.diag(cov), 0.0))
    s = np.where(np.isfinite(np.diag(cov)), s, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(s, s)
    return {n: float(v) for n, v in zip(names, s)}, corr


def log_jacobian(prob, steps, h: float = 1e-3) -> np.ndarray:
    """Central-difference Jacobian of ``prob.log_response`` at ``p = 0`` (N, npar).

    Parameters
    ----------
    prob : UpdateProblem or CostProblem-like
        Anything with ``log_response(p) -> (nf, ns, na)``.
    steps : ndarray, shape (npar,)
        Parameter scales (standard changes); the difference step is ``h`` times each.
    h : float
        Relative step.

    Returns
    -------
    ndarray, shape (nf * ns * na, npar)
        ``d log|H| / dp``.
    """
    cols = []
    for i, d in enumerate(steps):
        e = np.zeros(len(steps))
        e[i] = h * d
        cols.append(((prob.log_response(e) - prob.log_response(-e)) / (2 * h * d)).ravel())
    return np.array(cols).T


def fitted_std(prob, measured, names, steps) -> dict:
    """Standard deviation of each parameter fitted by :func:`~sdctrl.update`: the larger of the
    noise's and the sensors' scatter (module notes).

    Parameters
    ----------
    prob : UpdateProblem
        The problem solved again at the optimum (``p = 0`` there).
    measured : Measured
        The test.
    names : sequence of str
        Parameter names.
    steps : ndarray
        Standard changes of the parameters (difference steps).

    Returns
    -------
    dict
        Name -> standard deviation of the fitted ``p``.
    """
    J = log_jacobian(prob, steps)
    e = prob.log_response(np.zeros(len(steps))) - measured.logH
    var = log_point_variance(measured.frf, e.shape, residual=e, npar=len(steps))
    noise = std_and_correlation(names, parameter_covariance(J, var.ravel()))[0]
    groups = channel_groups(e.shape, stacked=False)
    C = None if groups is None else scatter_covariance(J, e.ravel(), groups)
    if C is None:
        return noise
    scatter = np.sqrt(np.clip(np.diag(C), 0.0, None))
    return {k: float(max(v, s)) if np.isfinite(v) else v
            for (k, v), s in zip(noise.items(), scatter)}
