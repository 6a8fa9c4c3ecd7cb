"""Sensor-to-sensor scatter of fitted coordinates: their uncertainty from the data, for a
diagnosis's fitted sizes (:mod:`sdctrl.diagnosis._effect_statistics`) and an update's
parameters (:mod:`sdctrl.updating._update_statistics`).

The Cramer-Rao covariance ``(sigma^2 / 2) (J^T J)^-1`` of
:mod:`sdctrl.diagnosis._effect_statistics` is the scatter that the measurement noise alone
gives the fitted coordinates ``x``.  When the
nominal model is itself slightly wrong (a reduction's truncation, data that are another
reduction of the structure) the fit carries a bias this covariance does not see: an added
dashpot sharing its node with a mass came out 0.7-1.2% off, 17-28 of its noise standard
deviations.  Such model error is rarely common to every channel -- some sensors pull the
sizes one way, others the other way -- so the data measure it: leave one sensor out and
refit, and the sizes move by

    ``x_(g) - x = -(A - A_g)^-1 J_g^T r_g``,  ``A = J^T J``,  ``A_g = J_g^T J_g``

(the Gauss-Newton step of the reduced least squares from the joint fit's optimum, where
``J^T r = 0``: the linearisation (3.55)-(3.56) of the fit on the complex logLS residual
(3.12); ``J_g``, ``r_g`` the stacked rows ``[Re; Im]`` of sensor ``g``'s channels).  On the
trusses' shared node these steps match refits without each sensor to 3% of the shift.  The
delete-one-sensor jackknife sums their squares; it overstates the noise's scatter by the
sensors' leverage (1.19 x the Cramer-Rao standard deviation on the plate, pure noise), so
the covariance kept is the leverage-corrected form of the same leave-outs, the
cluster-robust ``HC2`` sandwich (Bell & McCaffrey's bias-reduced linearisation)

    ``C = A^-1 [sum_g J_g^T (I - P_gg)^-1/2 r_g r_g^T (I - P_gg)^-1/2 J_g] A^-1``,

``P_gg = J_g A^-1 J_g^T`` the sensor's leverage.  Under pure noise (a correct model) it is
unbiased for a linear fit, ``E C = (sigma^2 / 2) A^-1``: measured 0.91-1.04 x the
Cramer-Rao standard deviation (rms over 20-40 noise draws; a dashpot, a mass, a spring, a
delay and a missing mode on five members of the family), against 0.99-1.34 for the plain
jackknife; under the shared-node model error it is 1.3% (truss) and 2.0% (truss_high) of
the dashpot, about twice its bias.  A model error common to every sensor does not scatter
and is not seen: a beam loss's 0.07% bias on the ladder and the plate (the data's reduction)
stays 7-12 standard deviations away at 1% noise, the cluster's mass of the two-effect case
(0.2% bias) 3.2 (issue 23, open; leaving out blocks of lines instead, measured, covers the
ladder's and the cluster's but not the plate's).  Computed in the ``p`` coordinates:
``J_g^T f(P_gg) = f(A_g A^-1) J_g^T`` gives ``A^-1/2 (I - M_g)^-1/2 A^-1/2 J_g^T r_g``
with ``M_g = A^-1/2 A_g A^-1/2``; no new evaluation of the model.  A direction
that the left-out sensor alone determines (leverage 1: a free mode's modal observability at
that sensor, a residual term's entry) gets nothing from that sensor: the noise covariance
stays the floor of the standard deviations
(:func:`sdctrl.diagnosis._effect_statistics.joint_std`).

Groups are the sensors (every channel of a sensor shares its location and so its model
error), or the channels when there are fewer than ``MIN_GROUPS`` sensors; with fewer than
``MIN_GROUPS`` channels the data say too little of their own scatter and there is none.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_GROUPS", "channel_groups", "scatter_covariance"]

#: fewest groups (sensors, else channels) for a scatter (below this it says little)
MIN_GROUPS = 5
#: leverages above ``1 - FULL`` are a direction the left-out group alone determines
FULL = 1e-8


def channel_groups(shape, stacked: bool = True) -> np.ndarray | None:
    """Group of each row of a stacked residual ``[Re r; Im r]`` of data ``shape``.

    Parameters
    ----------
    shape : tuple of int
        ``(nf, ns, na)``: lines, data sensors, data actuators.
    stacked : bool
        Rows ``[Re r; Im r]`` (a complex residual); False: one row per point (a real one,
        such as the update's ``log|H|`` residual).

    Returns
    -------
    ndarray of int, shape (2 nf ns na,) (``nf ns na`` unstacked), or None
        The row's sensor when ``ns >= MIN_GROUPS``, else its channel ``(sensor, actuator)``
        numbered ``i na + j`` when ``ns na >= MIN_GROUPS``, else None (no scatter).
    """
    nf, ns, na = (int(n) for n in shape)
    if ns >= MIN_GROUPS:
        per = np.repeat(np.arange(ns), na)
    elif ns * na >= MIN_GROUPS:
        per = np.arange(ns * na)
    else:
        return None
    rows = np.tile(per, nf)
    return np.tile(rows, 2) if stacked else rows


def scatter_covariance(J, r, groups) -> np.ndarray | None:
    """Leverage-corrected leave-one-group-out covariance of least-squares coordinates
    (``HC2``, module notes).

    Parameters
    ----------
    J : ndarray, shape (n, p)
        Stacked Jacobian ``[Re; Im] d r / dx`` at the fit.
    r : ndarray, shape (n,)
        Stacked residual ``[Re r; Im r]`` at the fit; projected off the columns of ``J``
        (the residual at the linearised optimum), so that a fit stopped short of its optimum
        (the joint refit stops within about a tenth of a standard deviation, a lone effect
        keeps its own fit) does not count its remaining step as scatter.
    groups : ndarray of int, shape (n,)
        Group of each row (:func:`channel_groups`), numbered from 0.

    Returns
    -------
    ndarray, shape (p, p), or None
        ``C``; None when ``J^T J`` is singular or not finite.
    """
    d = np.sqrt(np.sum(J * J, axis=0))
    if np.any(d == 0) or not np.all(np.isfinite(d)):
        return None
    Jn = J / d                                   # columns of unit norm
    w, V = np.linalg.eigh(Jn.T @ Jn)
    if w[0] <= w[-1] * 1e-14:
        return None
    half = (V / np.sqrt(w)) @ V.T                # A^-1/2 (scaled coordinates)
    r = r - Jn @ (half @ (half @ (Jn.T @ r)))      # the residual at the linearised optimum
    order = np.argsort(groups, kind="stable")
    bounds = np.searchsorted(groups[order], np.arange(int(groups.max()) + 2))
    S = np.zeros((J.shape[1], J.shape[1]))
    for g in range(bounds.size - 1):
        rows = order[bounds[g]:bounds[g + 1]]
        Jg = Jn[rows]
        mu, U = np.linalg.eigh(half @ (Jg.T @ Jg) @ half)
        f = np.where(mu < 1 - FULL, 1 / np.sqrt(np.clip(1 - mu, FULL, None)), 0.0)
        step = half @ ((U * f) @ (U.T @ (half @ (Jg.T @ r[rows]))))
        S += np.outer(step, step)
    return S / np.outer(d, d)
