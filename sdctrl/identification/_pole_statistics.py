"""Statistics of an identified complex-mode model under the test's noise (thesis 3.4).

The identified poles minimise the variable-projection cost ``sum_c ||P_perp(theta) y_c||^2``
(3.16) with the residues projected out (``y_c`` the stacked ``[Re; Im]`` data of channel
``c``, ``theta`` the real and imaginary parts of the poles).  Their sensitivity to the data
is the implicit-function relation (3.56): to first order ``d theta = A^-1 sum_c B_c^T dy_c``
with ``B_c = P_perp D_c``, ``D_c = d(Phi C_c)/d theta`` at fixed coefficients (the
Gauss-Newton, Kaufman, Jacobian of the residual) and ``A = sum_c B_c^T B_c``.  The
coefficients follow (3.58): ``dC_c = Phi^+ dy_c - Phi^+ D_c d theta``, a direct part and a
part through the poles.  With independent noise of variance ``W_c^2`` on each stacked point
(the point variance ``|H|^2 (1 - coherence)`` (3.59) when the FRF has a coherence, else
estimated from the residual) the covariance of ``[theta; C_1 ... C_m]`` is

* ``S = Cov(theta) = A^-1 (sum_c B_c^T W_c^2 B_c) A^-1`` (a sandwich: the fit is unweighted);
* ``Cov(C_c, theta) = K_c A^-1 - M_c S``;
* ``Cov(C_c, C_d) = delta_cd V_c - K_c A^-1 M_d^T - M_c A^-1 K_d^T + M_c S M_d^T``;

with ``M_c = Phi^+ D_c``, ``K_c = Phi^+ W_c^2 B_c`` (zero for equal noise on every line),
``V_c = Phi^+ W_c^2 Phi^+^T``.  These small blocks are kept (:class:`FitStatistics`), not
the full covariance, which would be quadratic in the number of channels.  A fit with line
weights ``L`` (``cm.search.weighting == "level"``, :mod:`~sdctrl.identification._line_weights`)
is the unweighted fit of ``L y_c`` on the basis ``L Phi``: the same blocks, of the weighted
data, basis and derivatives, with the noise's variance ``L^2 W_c^2``.

Data taken with an exponential window ``exp(-t/tau)`` on the responses (impact tests,
``frf.exponential_tau``) do not have independent lines: the window's spectrum spreads the
noise of each line over its neighbours, with the correlation ``a / (a + 2 pi j d)`` between
lines ``d`` apart, ``a = 2 T / tau``
(:func:`~sdctrl.identification._line_correlation.line_correlation`; 0.83 in modulus between
neighbours for a window ending at 1%).  ``W_c^2`` is then the full covariance
``sig_k sig_l rho(k - l)`` over the lines, applied by one convolution along them
(:func:`~sdctrl.identification._line_correlation.noise_times`), with ``sig_k^2`` the point
variance's running mean over :data:`SMOOTH_LINES` lines (the products ``sig_k sig_l`` of square
roots of per-line estimates -- exponential laws for two averages -- are biased low by up to
``pi/4``; the noise variance of an H1 estimate, the sensor's noise over the force spectrum,
is smooth over the lines).  Correlated noise moves the poles more than independent noise of the
same variance -- it looks like the smooth responses the poles fit: on roving-hammer surveys
(:func:`sdctrl.testbeds.survey`) the scatter of frequency and damping over 30 draws was
(plate, ladder) 1.2-2.4 times the prediction with independent lines, 0.76-1.32 with the
window's correlation (two hits per point, where (3.59) is unbiased, see below).

The point variance ``|H|^2 (1 - coherence)`` (3.59) is that of an FRF whose coherence is the
point's own signal-to-noise ratio.  For an H1 estimate from ``n_d`` averages with its
ordinary coherence ``g`` estimated from the same averages, ``E[1 - g] = (1 - g_true)
(n_d - 1) / n_d`` and the estimate's variance is ``|H|^2 E[1 - g] / (n_d - 1)``: (3.59)
overstates it ``n_d - 1`` times (conservative; exact for two averages).  Neither the
coherence's scatter over the lines nor the fit residual (dominated by the model's own error
on real tests) tells ``n_d`` reliably: the FRF records it (``FRF.averages``, set by
:func:`~sdctrl.impact_frf` to the number of hits) and the statistics divide (3.59) by
``n_d - 1`` (:func:`~sdctrl.identification._variance.recorded_divisor`); an FRF that does
not record it keeps the conservative variance.  A coherence identically 1 (one
record: no information on the noise) falls back to the residual.

Without a coherence, the residual's second differences over correlated lines keep only
``g = 6 - 8 Re rho(1) + 2 Re rho(2)`` of the noise's variance instead of 6 (1.24 for a
window ending at 1%), and are divided by it; the model's own error, which they no longer
suppress as well, then dominates on real tests: on the surveys above with the coherence
removed and the structure fixed the scatter is 0.06-0.33 of the prediction (conservative;
give the coherence).  With the automatic selection (a survey read from a file: no coherence,
no record of the window; 20 draws, the plate 30) the scatter is 0.45-1.22 of the prediction
on the truss, 0.72-1.78 on the ladder, 0.45-1.16 on the plate
(:mod:`~sdctrl.identification._level_choice`; 0.31-1.21 with the larger of the two levels).

The residual-based noise variance is local and heteroscedastic (as in the significance
test, :mod:`sdctrl.identification._noise`), from the second differences of the residual
over the lines, ``|r_{i-1} - 2 r_i + r_{i+1}|^2 / 6``: independent noise passes them with
its variance, while the model's own error (modes outside the band that the asymptotic
terms do not reproduce, smooth over the lines) and the part of the noise the fit absorbs
(smooth combinations of the basis) do not -- the raw residual counts that error as noise
and overstated the standard deviations up to 14 times (ladder, 1%: scatter 0.1-0.6 of the
prediction; 0.76-1.14 from second differences); then :func:`_level`.  The pole search runs
on data compressed to their dominant columns; the statistics are the full-data fit's, which
it matches when the compression keeps the signal (``info["compression_residual"]`` small).
Internal module: the functions trust their inputs (validated by the callers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.triangular import solve_upper
from sdctrl._lib.validate import QUANTITY_POWER
from sdctrl.identification._level_choice import chosen_level
from sdctrl.identification._line_correlation import (difference_gain, local_mean,
                                                     noise_correlation, noise_times)
from sdctrl.identification._line_weights import line_weights
from sdctrl.identification._noise import point_variance, running_median
from sdctrl.identification._residues import LSQ, basis, stack

__all__ = ["COND_MAX", "FitStatistics", "coefficient_variance", "fit_statistics", "pole_std",
           "undetermined"]

#: lines of the running mean of the point variance when lines are correlated (module notes)
SMOOTH_LINES = 21


@dataclass(frozen=True, eq=False)
class FitStatistics:
    """Covariance of an identified complex-mode model's parameters, in blocks (module notes).

    Parameters are ``theta = [Re l_1, Im l_1, ..., Re l_n, Im l_n]`` (rad/s) and, for each
    data channel ``c`` (sensor-major, ``c = s * na + a``), the real basis coefficients
    ``C_c`` (q,) of :func:`~sdctrl.identification._residues.basis` (two per pole, ``Re R``
    and ``Im R``, for the complex model; then ``E`` and ``F``).

    Parameters
    ----------
    S : ndarray, shape (2n, 2n)
        Covariance of ``theta``.
    A_inv : ndarray, shape (2n, 2n)
        Inverse of the Gauss-Newton matrix ``J^T J`` of the poles.
    M, K : ndarray, shape (m, q, 2n)
        ``Phi^+ D_c`` and ``Phi^+ W_c^2 B_c`` per channel.
    V : ndarray, shape (m, q, q)
        Direct covariance ``Phi^+ W_c^2 Phi^+^T`` of each channel's coefficients.
    model : str
        Parametrisation of the coefficients ("complex" or "real").
    asymptotic : tuple of bool
        Whether the coefficients hold ``E`` and ``F``.
    noise : str
        Where the noise variance came from: "coherence" or "residual".
    """

    S: np.ndarray
    A_inv: np.ndarray
    M: np.ndarray
    K: np.ndarray
    V: np.ndarray
    model: str = "complex"
    asymptotic: tuple[bool, bool] = (True, True)
    noise: str = "residual"

    @property
    def n(self) -> int:
        """Number of poles."""
        return self.S.shape[0] // 2

    def __repr__(self) -> str:
        return (f"FitStatistics(n={self.n}, channels={self.V.shape[0]}, "
                f"noise={self.noise!r})")


def fit_statistics(cm, data, model="complex", asymptotic=(True, True), n_averages=1,
                   poles_fixed=False):
    """Covariance blocks of ``cm``'s parameters fitted to ``data`` (3.56)-(3.59).

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model (displacement residues, poles in rad/s).
    data : FRF
        The lines it was fitted to (its band), same channels.
    model : {"complex", "real"}
        Parametrisation of the fit.
    asymptotic : (bool, bool)
        Whether ``E`` and ``F`` were fitted.
    n_averages : int
        Averages behind the coherence (divides the point variance 3.59).
    poles_fixed : bool
        The poles were given, not estimated: their covariance is zero and the residues
        have only the direct part of (3.58).

    Returns
    -------
    FitStatistics or None
        None when the data leave no degree of freedom for the noise.  A singular
        Jacobian of the poles gives statistics of the poles the data determine
        (pseudo-inverse, :func:`undetermined`), NaN for the others.
    """
    nf, ns, na = data.H.shape
    m = ns * na
    s = 2j * np.pi * data.freq
    k = QUANTITY_POWER[data.quantity]
    lam = _poles_in_data(cm)
    n = lam.size
    L = line_weights(data.H.reshape(nf, m)) if _level_weighted(cm) else None
    Phi = basis(lam, s, k, model, asymptotic, L)
    q = Phi.shape[1]
    if 2 * nf * m <= q * m + 2 * n:
        return None
    lsq = LSQ(Phi)
    Pinv = solve_upper(lsq.Rr, lsq.Q.T) / lsq.scale[:, None]
    H = data.H.reshape(nf, m) if L is None else data.H.reshape(nf, m) * L[:, None]
    C = Pinv @ stack(H)                                               # (q, m)
    npp = 2 if model == "complex" else 1
    G = _basis_derivative(lam, s, k, model)
    G = stack((G if L is None else G * L[:, None, None]).reshape(nf, -1))   # (2nf, 2n npp)
    Gp = G - lsq.Q @ (lsq.Q.T @ G)                                   # P_perp dPhi/dtheta
    Cp = C[(np.arange(2 * n) // 2)[:, None] * npp + np.arange(npp)]  # (2n, npp, m)
    # P_perp D_c of every channel, pole-major (2n, m, 2nf): contiguous in the lines
    Bq = np.matmul(Cp.transpose(0, 2, 1),
                   np.ascontiguousarray(Gp.reshape(2 * nf, 2 * n, npp).transpose(1, 2, 0)))
    B = Bq.transpose(2, 0, 1)                                        # (2nf, 2n, m) view
    A = np.einsum("aubv,aubv->ab", (Gp.T @ Gp).reshape(2 * n, npp, 2 * n, npp),
                  np.tensordot(Cp, Cp, axes=([2], [2])))              # sum_c B_c^T B_c
    A_inv = np.zeros_like(A) if poles_fixed else _gauss_newton_inverse(A)
    rho = noise_correlation(cm, data)
    var = point_variance(data, n_averages)
    if var is not None:
        var, noise = var.reshape(nf, m), "coherence"
        var = var if L is None else var * L[:, None] ** 2
    else:
        Yfit = stack(Phi) @ C
        var = _residual_variance(stack(H) - Yfit, Yfit, lsq.Q, (Gp, Cp), A_inv, rho)
        noise = "residual"
    sig = np.sqrt(var if rho is None else local_mean(var, SMOOTH_LINES))
    WBq = np.ascontiguousarray(noise_times(B, sig, rho).transpose(1, 2, 0))   # Sigma_c B_c
    S = A_inv @ (Bq.reshape(2 * n, -1) @ WBq.reshape(2 * n, -1).T) @ A_inv
    M = np.einsum("pau,aum->mpa", (Pinv @ G).reshape(q, 2 * n, npp), Cp)   # Phi^+ D_c
    K = (WBq.reshape(2 * n * m, 2 * nf) @ Pinv.T).reshape(2 * n, m, q).transpose(1, 2, 0)
    WP = noise_times(np.broadcast_to(Pinv.T[:, :, None], (2 * nf, q, m)), sig, rho)
    V = np.matmul(Pinv, WP.transpose(2, 0, 1))                      # (m, q, q)
    return FitStatistics(S=0.5 * (S + S.T), A_inv=A_inv, M=M, K=K, V=V, model=model,
                         asymptotic=tuple(bool(a) for a in asymptotic), noise=noise)


def _level_weighted(cm) -> bool:
    """Whether ``cm`` was fitted with line weights (:mod:`._line_weights`): its statistics
    are then those of the weighted fit (data, basis and noise weighted alike)."""
    return getattr(getattr(cm, "search", None), "weighting", None) == "level"


def _poles_in_data(cm) -> np.ndarray:
    """The poles as the data see them: an identified model of data taken with an exponential
    window ``exp(-t/tau)`` carries the corrected poles (``real + 1/tau``); its data hold
    them shifted by ``-1/tau`` (rad/s)."""
    tau = getattr(cm, "exponential_tau", None)
    lam = np.asarray(cm.poles, complex)
    return lam if tau is None else lam - 1.0 / tau


#: relative eigenvalue of ``J^T J`` below which its direction is not determined by the data
COND_MAX = 1e14


def _gauss_newton_inverse(A):
    """Inverse of the Gauss-Newton matrix ``A`` of the poles, or its pseudo-inverse on the
    directions the data determine (eigenvalues above ``max / COND_MAX``) when it is
    singular: two poles standing for one mode beyond the band, a pole far from every
    line.  The null directions get zero in the inverse and :func:`undetermined` names
    the poles they involve (their statistics are NaN, 3.56)."""
    d, U = np.linalg.eigh(0.5 * (A + A.T))
    dmax = float(d.max()) if d.size else 0.0
    if d.size and d.min() > dmax / COND_MAX:
        return np.linalg.inv(A)
    keep = d > dmax / COND_MAX
    return (U[:, keep] / d[keep]) @ U[:, keep].T


def undetermined(stats: FitStatistics) -> np.ndarray:
    """Poles whose parameters the data do not determine (n,) bool.

    The inverse Gauss-Newton matrix is a pseudo-inverse with exact zero eigenvalues on
    the directions the data leave free (:func:`_gauss_newton_inverse`); a pole is
    undetermined when more than 1e-3 of one of its parameters (``Re l``, ``Im l``) lies
    in that null space.

    Parameters
    ----------
    stats : FitStatistics
        Covariance blocks of the fit.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    n = stats.n
    if n == 0 or not np.any(stats.A_inv):
        return np.zeros(n, bool)                       # poles given (fixed): no pole part
    d, U = np.linalg.eigh(0.5 * (stats.A_inv + stats.A_inv.T))
    null = d <= 0.1 * float(d.max()) / COND_MAX      # kept: >= max / COND_MAX
    if not np.any(null):
        return np.zeros(n, bool)
    part = np.sum(U[:, null] ** 2, axis=1).reshape(n, 2)
    return np.any(part > 1e-3, axis=1)


def _basis_derivative(lam, s, k, model):
    """Derivatives of each pole's basis columns w.r.t. ``(Re l_j, Im l_j)``, complex
    (nf, 2n, npp): ``d H_c / d theta_a = G[:, a] @ C[rows of pole a // 2, c]``."""
    a = 1.0 / (s[:, None] - lam[None, :])                  # 1/(s - l)
    b = 1.0 / (s[:, None] - lam.conj()[None, :])           # 1/(s - l^*)
    if model == "complex":                                 # g1 = a + b, g2 = i (a - b)
        plus, minus = a**2 + b**2, a**2 - b**2
        d_re = np.stack([plus, 1j * minus], axis=-1)
        d_im = np.stack([1j * minus, -plus], axis=-1)
    else:                                                  # g = a b
        d_re = (a**2 * b + a * b**2)[..., None]
        d_im = 1j * (a**2 * b - a * b**2)[..., None]
    out = np.stack([d_re, d_im], axis=2).reshape(s.size, 2 * lam.size, -1)
    return out * (s**k)[:, None, None] if k else out


def _second_difference(X, nf):
    """Second differences over the lines of a stacked ``[Re; Im]`` array (2nf, ...), each
    block on its own: (2, nf - 2, ...)."""
    blocks = (X[:nf], X[nf:])
    return np.stack([b[:-2] - 2.0 * b[1:-1] + b[2:] for b in blocks])


def _residual_variance(r, Yfit, Q, GC, A_inv, rho=None):
    """Noise variance per stacked point from the fit residual (module notes).

    ``r``, ``Yfit`` (2nf, m) stacked; ``Q`` (2nf, q) the residues' orthonormal basis;
    ``GC = (Gp, Cp)``: the poles' projected Jacobian is ``B_c = Gp Cp_c`` per channel
    (``Gp`` (2nf, 2n npp), ``Cp`` (2n, npp, m)), ``A_inv`` its Gauss-Newton inverse.
    The second difference ``w^T r`` of the residual ``r = (I - P) e`` has the variance
    ``(w^T w - w^T P w) sigma^2`` (``w^T w = 6``): ``w^T P w`` is the leverage of the
    stencil for all fitted parameters (residues, asymptotic terms and poles).
    """
    nf = r.shape[0] // 2
    if nf < 5:
        e = (r[:nf] ** 2 + r[nf:] ** 2)
    else:
        Gp, Cp = GC
        na, npp, m = Cp.shape
        dr = _second_difference(r, nf)                                  # (2, nf-2, m)
        dQ = _second_difference(Q, nf)                                  # (2, nf-2, q)
        # second differences of B_c = Gp Cp_c, pole by pole: (2n, 2(nf-2) m), contiguous
        dG = _second_difference(Gp.reshape(2 * nf, na, npp), nf)        # (2, nf-2, 2n, npp)
        dB = np.matmul(dG.transpose(2, 0, 1, 3).reshape(na, -1, npp), Cp).reshape(na, -1)
        quad = np.sum((A_inv.T @ dB) * dB, axis=0).reshape(2, nf - 2, m)
        lev = np.sum(dQ * dQ, axis=2)[..., None] + quad
        g = difference_gain(rho) / 6.0
        d2 = np.sum(dr**2, axis=0) / np.maximum(g * (6.0 - 0.5 * np.sum(lev, axis=0)),
                                                0.3 * g)
        e = np.vstack([d2[:1], d2, d2[-1:]])
    return _level(e, Yfit[:nf] ** 2 + Yfit[nf:] ** 2)


def _level(e, shape):
    """``E[r_re^2 + r_im^2]`` per line (nf, m) from the point estimates ``e`` (second
    differences) and the fitted ``|H|^2`` (``shape``): each line's choice
    (:func:`~sdctrl.identification._level_choice.chosen_level`) between an additive level and
    a level proportional to the stencil ``(shape_(k-1) + 4 shape_k + shape_(k+1)) / 6`` (what a
    second difference of noise of variance ``b shape`` estimates: ``shape_k`` alone overstated
    ``b`` beside peaks narrower than the lines, e.g. the truss's 9.5 Hz damping std, scatter
    0.66 -> 0.74 of it), each a running median over the lines, its windows inside the data
    at the band's edges (the edge line repeated made the level of a mode there one line's
    estimate: 0.74 -> 0.89; lattice at 200 lines, first mode 0.57 -> 0.92), over ``ln 2``.
    An exact fit (both levels zero) has level zero.  Computed in the unit of the fitted
    ``|H|^2`` (a power of two: exact), so that it scales with the data's unit: a floor of
    1e-300 added to data of 1e-305 made the level a constant."""
    nf = e.shape[0]
    top = float(np.max(shape))
    unit = 2.0 ** np.round(np.log2(top)) if top > 0 else 1.0     # exact: the data's unit
    e, shape = e / unit, shape / unit
    tiny = 1e-300 + 1e-30 * top / unit
    win = max(41, nf // 20) if nf >= 82 else max(5, nf // 2)
    pad = np.vstack([shape[:1], shape, shape[-1:]])
    stencil = (pad[:-2] + 4.0 * pad[1:-1] + pad[2:]) / 6.0
    add = running_median(e, win, inside=True) / np.log(2.0)
    mult = running_median(e / (stencil + tiny), win, inside=True) * shape / np.log(2.0)
    level = chosen_level(e, add + tiny, mult + tiny)
    return unit * np.where(np.maximum(add, mult) > 0.0, level, 0.0)


def pole_std(stats: FitStatistics, poles) -> tuple[np.ndarray, np.ndarray]:
    """One standard deviation of each pole's frequency (Hz) and damping ratio.

    ``f = |l| / 2 pi``, ``zeta = -Re l / |l|``; their gradients with respect to
    ``(Re l, Im l)`` map each pole's 2x2 covariance block of ``S``.

    Parameters
    ----------
    stats : FitStatistics
        Covariance blocks of the fit (None: nothing known).
    poles : ndarray, shape (n,)
        The poles (rad/s).

    Returns
    -------
    frequency_std, damping_std : ndarray, shape (n,)
        NaN where the data do not determine them.
    """
    lam = np.asarray(poles, complex)
    n = lam.size
    if stats is None or stats.n != n:
        return np.full(n, np.nan), np.full(n, np.nan)
    x, y = lam.real, lam.imag
    r = np.abs(lam)
    gf = np.stack([x, y], axis=1) / (r[:, None] * 2 * np.pi)           # df/d(x, y)
    gz = np.stack([-y**2, x * y], axis=1) / r[:, None] ** 3            # dzeta/d(x, y)
    blocks = stats.S.reshape(n, 2, n, 2)[np.arange(n), :, np.arange(n), :]   # (n, 2, 2)
    vf = np.einsum("ja,jab,jb->j", gf, blocks, gf)
    vz = np.einsum("ja,jab,jb->j", gz, blocks, gz)
    ok = np.isfinite(vf) & np.isfinite(vz) & (vf >= 0) & (vz >= 0) & ~undetermined(stats)
    return (np.where(ok, np.sqrt(np.abs(vf)), np.nan),
            np.where(ok, np.sqrt(np.abs(vz)), np.nan))


def coefficient_variance(stats: FitStatistics, direct_only: bool = False) -> np.ndarray:
    """Variance of each channel's coefficients, both parts of (3.58).

    Parameters
    ----------
    stats : FitStatistics
        Covariance blocks of the fit.
    direct_only : bool
        Only the direct part ``Phi^+ W^2 Phi^+^T`` (fixed poles).

    Returns
    -------
    ndarray, shape (q, m)
    """
    direct = np.einsum("mpp->pm", stats.V)
    if direct_only:
        return direct
    cross = np.einsum("mpa,ab,mpb->pm", stats.K, stats.A_inv, stats.M)
    through = np.einsum("mpa,ab,mpb->pm", stats.M, stats.S, stats.M)
    var = np.maximum(direct - 2 * cross + through, 0.0)
    bad = undetermined(stats)
    if np.any(bad):                          # the coefficients of undetermined poles
        npp = 2 if stats.model == "complex" else 1
        rows = (np.flatnonzero(bad)[:, None] * npp + np.arange(npp)).ravel()
        var[rows] = np.nan
    return var


def part_std(stats: FitStatistics | None, poles, shape: tuple,
             direct_only: bool = False) -> tuple:
    """Standard deviations of the real and imaginary parts of the poles and residues.

    The poles' from the diagonal of ``S`` (3.56); the residues' from (3.58)
    (:func:`coefficient_variance`: the complex parametrisation's coefficients are ``Re R``
    and ``Im R``; the real one's single coefficient ``c`` is ``R (l - conj l)``, so ``|R|``'s
    variance is ``var c / |l - conj l|^2``, shared equally by the two parts).  Used for the
    residue std of :func:`~sdctrl.identification._variance.residue_std` and for the
    uncertainty of residual dynamics (:class:`~sdctrl.modal.ResidualDynamics`).

    Parameters
    ----------
    stats : FitStatistics or None
        Covariance blocks of the fit.
    poles : ndarray, shape (n,)
        The poles (rad/s).
    shape : tuple of int
        ``(n, ns, na)`` of the model's residues.
    direct_only : bool
        Only the direct part of (3.58) for the residues (poles held fixed).

    Returns
    -------
    pole_std : ndarray, shape (n,), complex
        Std of ``Re l`` in ``.real``, of ``Im l`` in ``.imag`` (rad/s); NaN where undetermined.
    residue_std : ndarray, shape (n, ns, na), complex
        Std of ``Re R`` in ``.real``, of ``Im R`` in ``.imag``; NaN where undetermined.
    """
    n = shape[0]
    if stats is None or stats.n != n:
        return np.full(n, np.nan, complex), np.full(shape, np.nan, complex)
    d = np.sqrt(np.abs(np.diag(stats.S)))
    bad = undetermined(stats)
    pole = np.empty(n, complex)
    pole.real, pole.imag = np.where(bad, np.nan, d[0::2]), np.where(bad, np.nan, d[1::2])
    var = coefficient_variance(stats, direct_only)                       # (q, m)
    if stats.model == "complex":
        re, im = np.sqrt(var[0:2 * n:2]), np.sqrt(var[1:2 * n:2])
    else:
        lam = np.asarray(poles, complex)
        re = im = np.sqrt(var[:n] / (2 * np.abs(lam - lam.conj())[:, None] ** 2))
    res = np.empty(re.shape, complex)
    res.real, res.imag = re, im                  # NaN kept part by part
    return pole, res.reshape(shape)
