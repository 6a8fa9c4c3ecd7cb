"""Noise field and significance test of the automatic pole selection (thesis 3.2.1).

Noise in real tests is heteroscedastic: multiplicative (larger at peaks), an additive
floor (dominant at antiresonances and, for accelerations, at low frequency), and unequal
between channels.  A pole is kept, and a residual peak becomes a candidate, only if its
cost change exceeds what pure noise would give:

* the noise variance per line and data column is estimated locally and robustly
  (running medians of the residual over ``max(41, nf/20)`` lines, standardised by the
  leverage ``h`` of each line, ``|r|^2 / (1 - h)``, since a pole absorbs part of the noise
  of the lines it fits), as the larger of an additive level and a level proportional to
  a shape: the point variance ``|H|^2 (1 - coherence)`` (3.59) when ``frf.coherence`` is
  given, else the fitted ``|H|^2`` (multiplicative noise);
* out-of-band poles (issue 22) meet a second field: the same two levels estimated from
  the second differences of the residual along the lines,
  ``|r_(i-1) - 2 r_i + r_(i+1)|^2 / 6``, the lower of the two fields kept.  For noise
  independent from line to line both agree, while a residual smooth in frequency (the
  tails of modes outside the band that the asymptotic terms ``E``, ``F/s^2`` of (3.7) do
  not carry) is no noise and would otherwise raise the threshold that the very poles
  which remove it must pass.  In-band poles meet the same lower field only when the
  data show noise independent between lines (:meth:`NoiseTest.independent`; the
  selection's rules set :attr:`NoiseTest.lower_when_independent`): an FRF estimated
  from windowed time records (``impact_frf``, ``estimate_frf``, or the same data
  without coherence) has noise correlated over several lines by the windows (measured
  on a simulated hammer test: correlation 0.8 between neighbouring lines, second
  differences 30 times below the noise), which an in-band pole of small damping can
  fit, while an out-of-band pole, smooth over the band on the scale of its distance to
  the edge, cannot; an FRF that records an exponential window (or whose residual decays
  over the record) keeps the direct field for the residual scan, and its poles'
  significance meets the lower field with the second differences divided by their gain
  for the window's correlation (:attr:`NoiseTest.significance_gain`, 1.24 instead of 6
  for a window ending at 1%: unbiased for that noise, far below a smooth misfit; the
  rules' module notes give the real hammer data this holds).  With independent noise
  the direct field holds the model's error too: on the testbed family's cluster at 1%
  noise, before the modes above the band were fitted, it was up to 10^4 times the noise
  on some channels (the second differences within 25% of it), and the weakest blade
  mode was never kept;
* it is weighted by the diagonal of the projector on the pole's columns (orthogonalised
  against the other poles): a pole on a peak meets the noise of the peak;
* the cost change of a noise-fitting pole, ``sum_c s_c chi2(npp)`` over the data
  columns, is approximated by a scaled chi-square with the same mean and variance
  (Welch-Satterthwaite), so that a few noisy channels give the heavier tail they have;
  the threshold is its ``1e-3/nf`` quantile (the pole could sit at any line) times
  ``significance`` (2 by default, covering the two nonlinear parameters fitted).

The rank-one test of the residues (3.2.2, :meth:`ComplexModeModel.singular_value_ratios`)
is not used to reject poles: a real mode at the noise level (a weak local mode) has a
far-from-dyadic residue too, single-input data carry no such information, and the
significance test already rejects the noise poles it would catch.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.chisquare import chi2_isf
from sdctrl._lib.triangular import solve_upper
from sdctrl.data._coherence import measured_coherence
from sdctrl.identification._residues import basis_derivatives, stack

__all__ = ["NoiseTest", "noise_field", "point_variance", "projector_diagonal", "running_median"]

#: lags (lines) of the second differences of the smooth noise field (module notes)
SMOOTH_LAGS = (1,)


def point_variance(data, n_averages=1):
    """The point variance ``|H|^2 (1 - coherence) / n_averages`` (3.59) of ``data``'s
    lines, shape of ``data.H``; None when the FRF carries no coherence measuring its noise
    (:func:`~sdctrl.data._coherence.measured_coherence`: the statistics then take the
    residual's)."""
    coh = measured_coherence(data)
    if coh is None:
        return None
    return np.abs(data.H) ** 2 * (1.0 - coh) / n_averages


def running_median(X: np.ndarray, win: int, inside: bool = False) -> np.ndarray:
    """Running median over ``win`` lines (axis 0, edges held), per column of ``X`` (nf, k).

    Evaluated every ``win // 8`` lines and interpolated linearly in between: the noise
    level is smooth on the scale of the window, and the cost is ``8 nf k`` instead of
    ``nf k win``.

    Parameters
    ----------
    X : ndarray, shape (nf, k)
        Values per line and column.
    win : int
        Window length in lines (capped at ``nf``).
    inside : bool
        Near an edge, the window of ``win`` lines shifted to lie inside the data, instead
        of the edge line repeated (which makes the median there that one line's value).

    Returns
    -------
    ndarray, shape (nf, k)
    """
    nf = X.shape[0]
    win = int(min(win, nf))
    half = win // 2
    step = max(1, win // 8)
    centres = np.unique(np.append(np.arange(0, nf, step), nf - 1))
    if inside:                    # lines last (contiguous windows): (k, nf - win + 1, win)
        view = np.lib.stride_tricks.sliding_window_view(X.T.copy(), win, axis=1)
        starts = np.clip(centres - half, 0, nf - win)
    else:                         # edges held: (k, nf, win)
        Xp = np.concatenate([np.repeat(X[:1], half, axis=0), X,
                             np.repeat(X[-1:], win - 1 - half, axis=0)]).T.copy()
        view = np.lib.stride_tricks.sliding_window_view(Xp, win, axis=1)
        starts = centres
    # median of the sorted windows: the middle element, or the mean of the two middle
    # ones (the numbers of np.median and np.partition; numpy's vectorised sort of short
    # contiguous rows is several times faster than either here)
    h = win // 2
    srt = view[:, starts]                                               # (k, nc, win)
    srt.sort(axis=-1)
    if win % 2:
        med = srt[..., h].T                                             # (nc, k)
    else:
        med = 0.5 * (srt[..., h - 1] + srt[..., h]).T
    if centres.size == nf:
        return med
    t = np.arange(nf)
    j = np.clip(np.searchsorted(centres, t, side="right") - 1, 0, centres.size - 2)
    a = ((t - centres[j]) / (centres[j + 1] - centres[j]))[:, None]
    return (1 - a) * med[j] + a * med[j + 1]


def noise_field(r, Yfit, Q, shape, win: int, smooth: bool = False,
                direct: np.ndarray | None = None, gain: float = 6.0) -> np.ndarray:
    """Heteroscedastic noise variance ``E[r_re^2 + r_im^2]`` per line and data column.

    Two robust local estimates (running medians over ``win`` lines of the residual ``r``
    standardised by the leverage ``h`` of each line of the current basis ``Q``,
    ``e = |r|^2 / (1 - h)``, corrected by ``1/ln 2``, the mean/median ratio of the
    exponential law of ``r_re^2 + r_im^2``), the larger of which is kept at every line:

    * an additive level, ``median(e)`` (noise floor, antiresonances);
    * a level proportional to a shape ``s(f)``: ``median(e/s) s``, with ``s`` the
      point variance ``|H|^2 (1 - coherence)`` (3.59) when the coherence is known,
      else the fitted response ``|Y_fit|^2`` (multiplicative noise, larger at peaks).

    Parameters
    ----------
    r : ndarray, shape (2 nf, k)
        Stacked residual of the current fit.
    Yfit : ndarray, shape (2 nf, k)
        Stacked fitted data.
    Q : ndarray, shape (2 nf, p)
        Orthonormal basis of the current fit (leverages).
    shape : ndarray, shape (nf, k), or None
        Noise shape from the coherence; None uses ``|Y_fit|^2``.
    win : int
        Running-median window in lines.
    smooth : bool
        Also estimate the levels from second differences and keep the lower field (the
        noise seen by out-of-band poles; module notes).
    direct : ndarray, shape (nf, k), optional
        The field without ``smooth`` of the same arguments, when already computed.
    gain : float
        ``E|n_(i-1) - 2 n_i + n_(i+1)|^2 / sig^2`` of the noise (6 for independent lines,
        :func:`~sdctrl.identification._line_correlation.difference_gain` for correlated).

    Returns
    -------
    ndarray, shape (nf, k)
    """
    nf = r.shape[0] // 2
    lev = np.sum(Q * Q, axis=1)
    lev = 0.5 * (lev[:nf] + lev[nf:])                    # leverage of each line
    e = (r[:nf] ** 2 + r[nf:] ** 2) / np.maximum(1.0 - lev, 0.05)[:, None]
    shape = shape if shape is not None else Yfit[:nf] ** 2 + Yfit[nf:] ** 2
    tiny = 1e-300 + 1e-30 * float(np.max(shape))
    field = _level(e, shape, tiny, win) if direct is None else direct
    if smooth and nf >= 8:
        # the same from second differences of the residual along the lines: equal for
        # noise independent from line to line, far below for a residual smooth in
        # frequency (model error, the tails of modes outside the band), which is no
        # noise; used for out-of-band poles only (module notes)
        d = np.max([_level(_second_difference(r[:nf], r[nf:], lev, k, gain), shape, tiny,
                           win) for k in SMOOTH_LAGS if 2 * k < nf], axis=0)
        field = np.minimum(field, d)
    return field


def _level(e, shape, tiny, win):
    """Larger of the additive and the multiplicative running-median levels of ``e``."""
    add = running_median(e, win)
    mult = running_median(e / (shape + tiny), win) * shape
    return np.maximum(add, mult) / np.log(2.0)


def _second_difference(re, im, lev, k=1, gain=6.0):
    """``|r_(i-k) - 2 r_i + r_(i+k)|^2 / gain`` per line (edges repeated), standardised by
    the leverage like the residual: for noise of a smooth variance whose second
    differences have that gain (6: independent over ``k`` lines) its mean is the variance
    of one line."""
    a, b, c = slice(None, -2 * k), slice(k, -k), slice(2 * k, None)
    d = (re[a] - 2 * re[b] + re[c]) ** 2 + (im[a] - 2 * im[b] + im[c]) ** 2
    h = np.maximum(1.0 - (lev[a] + 4 * lev[b] + lev[c]) / 6, 0.05)
    d = d / (gain * h[:, None])
    return np.concatenate([np.repeat(d[:1], k, 0), d, np.repeat(d[-1:], k, 0)])


def projector_diagonal(G):
    """Diagonal of the projector on the columns of ``G`` (2nf, npp) per trial.

    Parameters
    ----------
    G : ndarray, shape (2 nf, T, npp)
        ``npp`` (1 or 2) columns for each of ``T`` trials.

    Returns
    -------
    ndarray, shape (2 nf, T)
    """
    if G.shape[-1] == 1:
        g = G[..., 0]
        return g * g / np.maximum(np.sum(g * g, axis=0), 1e-300)
    g0, g1 = G[..., 0], G[..., 1]
    a = np.sum(g0 * g0, axis=0)
    b = np.sum(g0 * g1, axis=0)
    c = np.sum(g1 * g1, axis=0)
    return (c * g0 * g0 - 2 * b * g0 * g1 + a * g1 * g1) / np.maximum(a * c - b * b,
                                                                       1e-300)


class NoiseTest:
    """Noise field and significance threshold of a pole-search problem (module notes).

    Parameters
    ----------
    prob : PoleProblem
        The pole-search problem (data ``Y``, poles' columns ``npp``).
    significance : float
        Multiplier of the noise threshold.
    shape : ndarray, shape (nf, k), optional
        Noise shape from the coherence (3.59), on the (compressed) data columns.
    """

    def __init__(self, prob, significance: float, shape=None):
        self.prob = prob
        self.nf = prob.s.size
        self.signif = significance
        self.shape = shape                      # noise shape (nf, k) from the coherence
        self.win = max(41, self.nf // 20)       # running-median window of the noise
        self.floor = 1e-13 * prob.normY2        # below: numerically zero cost change
        # every test meets the lower (second-difference) field when the data show noise
        # independent between lines (set by the selection's rules; module notes)
        self.lower_when_independent = False
        # noise correlated between lines: the significance meets the lower field, second
        # differences divided by this gain (set by the selection's rules; module notes)
        self.significance_gain = None

    def field(self, ev, smooth: bool = False) -> np.ndarray:
        """:func:`noise_field` of the fit ``ev``, computed once per fit (the pruning test,
        the residual scan and the acceptance of new poles meet the same fit): the lower
        field also without ``smooth`` when :attr:`lower_when_independent` is set and the
        data show independent noise (:meth:`independent`).

        Parameters
        ----------
        ev : dict
            An evaluation of :meth:`PoleProblem.evaluate` (the field is stored in it).

        Returns
        -------
        ndarray, shape (nf, k)
        """
        if not smooth and self.lower_when_independent and self.independent(ev):
            smooth = True                       # the smooth residual is no noise
        return self._field(ev, smooth)

    def _field(self, ev, smooth: bool) -> np.ndarray:
        """The direct (or, with ``smooth``, the lower) field of the fit ``ev``, cached."""
        key = "sig2s" if smooth else "sig2"
        if key not in ev:
            r = ev["r"]
            ev[key] = noise_field(r, self.prob.Y - r, ev["lsq"].Q, self.shape, self.win,
                                  smooth, ev.get("sig2") if smooth else None,
                                  self.significance_gain or 6.0)
        return ev[key]

    def independent(self, ev) -> bool:
        """Whether the data show noise independent between lines: the second-difference
        field agrees with the direct one (their median ratio above one half) where the
        residual is noise, most of the band; an FRF of windowed records whose window is
        not recorded has its second differences far below (30 times on a hammer test).
        Computed once per fit.

        Parameters
        ----------
        ev : dict
            The fit (:meth:`PoleProblem.evaluate`).

        Returns
        -------
        bool
        """
        if "independent" not in ev:
            direct = self._field(ev, False)
            ratio = self._field(ev, True) / np.maximum(direct, 1e-300)
            ev["independent"] = bool(np.median(ratio[direct > 0]) > 0.5)
        return ev["independent"]

    def threshold(self, s):
        """Noise threshold of a pole's cost change from per-column variances ``s`` (.., k).

        For pure noise the change is ``sum_c s_c chi2(npp)`` (``s_c`` the variance seen
        through the pole's projection in column ``c``); its law is approximated by a
        scaled ``g chi2(h)`` with the same mean and variance (Welch-Satterthwaite), so
        that columns with unequal noise (a few dominate) give the heavier tail they
        have.  The quantile is ``1e-3 / nf`` (the pole could sit at any line) and
        ``significance`` multiplies it.

        Parameters
        ----------
        s : ndarray, shape (..., k)
            Noise variance per data column seen through each pole's projection.

        Returns
        -------
        ndarray, shape (...)
        """
        npp = self.prob.npp
        s1 = np.sum(s, axis=-1)
        s2 = np.maximum(np.sum(s * s, axis=-1), 1e-300)
        g = s2 / np.maximum(s1, 1e-300)
        h = np.maximum(npp * s1 * s1 / s2, 1e-3)
        return self.signif * g * chi2_isf(h, 1e-3 / max(self.nf, 1))

    def significance(self, n: int, ev, side=None) -> np.ndarray:
        """Cost increase when each pole is removed, over its noise threshold (>1 keeps).

        The noise is estimated (:meth:`field`) from the residual of the full model,
        standardised by the leverage of each line (a pole absorbs part of the noise of
        the lines it fits: ``E r_i^2 = sigma_i^2 (1 - h_i)``), and weighted by where the
        pole's basis function lives (diagonal of the projector on its columns orthogonal
        to the others), so that a pole on a peak is compared with the larger noise at
        the peak and a pole in a noise floor with that floor.

        Parameters
        ----------
        n : int
            Number of poles of the fit.
        ev : dict
            The fit (:meth:`PoleProblem.evaluate`).

        Returns
        -------
        ndarray, shape (n,)
        """
        prob = self.prob
        npp = prob.npp
        nf = self.nf
        lsq = ev["lsq"]
        # one QR for all the poles: with A = Q R (scaled columns), the part of pole j's
        # columns S orthogonal to the others is B = Q R^-T[:, S] M_SS^-1 (M = R^-1 R^-T),
        # B^T B = M_SS^-1, and removing j raises the cost by tr(C_S^T M_SS^-1 C_S) and
        # the residual by B C_S (C: coefficients of the scaled columns)
        Rinv = solve_upper(lsq.Rr, np.eye(lsq.Rr.shape[0]))
        W = lsq.Q @ Rinv.T
        M = Rinv @ Rinv.T
        Cs = solve_upper(lsq.Rr, lsq.Q.T @ prob.Y)
        sig2 = self.field(ev) if self.significance_gain is None else self._field(ev, True)
        out = np.zeros(n, bool) if side is None else np.asarray(side) != 0
        sig2s = self.field(ev, smooth=True) if np.any(out) else sig2
        dJ = np.empty(n)
        sc = np.empty((n, sig2.shape[1]))
        for j in range(n):
            S = np.arange(j * npp, (j + 1) * npp)
            MSS = M[np.ix_(S, S)]
            Ginv = np.linalg.inv(MSS)
            B = W[:, S] @ Ginv
            dJ[j] = float(np.sum(Cs[S] * (Ginv @ Cs[S])))
            d = np.sum((B @ MSS) * B, axis=1)                           # projector diagonal
            dl = d[:nf] + d[nf:]
            sc[j] = 0.5 * (dl @ (sig2s if out[j] else sig2)) / npp     # per column
        return dJ / np.maximum(self.threshold(sc), self.floor)

    def log_damping_std(self, w, z, ev, poles) -> np.ndarray:
        """Standard deviation of ``ln zeta`` of the ``poles`` (indices) due to the noise.

        The sensitivity of the optimal poles to the data (3.56) is, to first order,
        ``dx = -(J^T J)^-1 J^T dY`` with ``J`` the (Kaufman) Jacobian of the residual with
        respect to ``x = [ln omega; ln zeta]``; with the noise field (:meth:`field`,
        independent lines and columns, half of ``E[r_re^2 + r_im^2]`` on each of the two
        rows of a line) the variance of parameter ``a`` is ``u^T J^T Sigma J u`` with
        ``u = (J^T J)^-1 e_a``.  A pole whose damping is not determined by the data (a
        bandwidth below the line spacing fitted to noise) has a standard deviation of
        ``ln zeta`` of order one or more; a resolved one far below one.

        Parameters
        ----------
        w, z : ndarray, shape (n,)
            Poles of the fit (rad/s, damping ratio).
        ev : dict
            Their evaluation (:meth:`PoleProblem.evaluate`).
        poles : array_like of int
            Poles whose damping uncertainty is wanted.

        Returns
        -------
        ndarray
            ``std(ln zeta)`` per pole in ``poles`` (inf when the Jacobian is singular).
        """
        prob = self.prob
        n, npp, nf = w.size, prob.npp, self.nf
        lsq, C = ev["lsq"], ev["C"]
        deriv = basis_derivatives(ev["lam"], w, z, prob.s, prob.k, prob.model, prob.weight)
        D = stack(deriv.transpose(1, 0, 2, 3).reshape(nf, 2 * n * npp))   # par a: cols a*npp
        D -= lsq.Q @ (lsq.Q.T @ D)                                       # P_perp dPhi/dx
        crow = (np.arange(2 * n) % n)[:, None] * npp + np.arange(npp)[None, :]
        Cp = C[crow.ravel()]                                             # (2n npp, k)
        G = (D.T @ D).reshape(2 * n, npp, 2 * n, npp)
        CC = (Cp @ Cp.T).reshape(2 * n, npp, 2 * n, npp)
        A = np.einsum("aubv,aubv->ab", G, CC)                           # J^T J
        sig2 = 0.5 * self.field(ev)                                     # per row of a line
        out = np.full(len(poles), np.inf)
        for i, j in enumerate(poles):
            e = np.zeros(2 * n)
            e[n + j] = 1.0
            try:
                u = np.linalg.solve(A, e)
            except np.linalg.LinAlgError:
                continue
            Ju = D @ (np.repeat(u, npp)[:, None] * Cp)                  # J u, (2nf, k)
            out[i] = np.sqrt(float(np.sum((Ju[:nf] ** 2 + Ju[nf:] ** 2) * sig2)))
        return out
