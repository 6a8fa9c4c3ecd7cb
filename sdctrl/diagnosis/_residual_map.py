"""The residual between a model and measured FRFs, where it concentrates, its noise level and
the information criterion that decides whether an effect is worth adding.

Costs (thesis 3.1.3).  The residual is the complex logarithm of the ratio of the predicted to
the measured response, ``r = Log H_M - Log H_I = Log(H_M / H_I)`` (principal branch, so the
phase difference is wrapped to ``(-pi, pi]``); the diagnosis error is the logLS cost (3.12)
taken with the complex logarithm, ``J = mean |r|^2`` over lines, sensors and actuators.  The
thesis notes that the complex log is the more accurate form; it is also the only one that sees
effects acting on the phase alone (a measurement delay).  The quadratic cost (3.11) is
reported alongside (relative form ``||H_M - H_I||_F / ||H_I||_F``).

Noise level.  Measurement noise is white from line to line while model errors are smooth in
frequency (or sharp only at the few lines of a resonance), so the second difference along
frequency of the residual, ``d_l = r_{l+1} - 2 r_l + r_{l-1}``, carries ``6 sigma^2`` of noise
variance and almost none of the model error.  With ``|d|^2`` exponential for complex Gaussian
noise, ``sigma^2 = median |d|^2 / (6 ln 2)``: the median ignores the lines where the model
error does vary quickly (shifted lightly damped peaks).

Information criterion.  For residuals that are complex Gaussian of variance ``sigma^2`` the
log-likelihood is ``-N J / sigma^2`` up to a constant (``N`` complex entries, ``2N`` real
observations), and adding an effect with ``k`` fitted parameters, chosen among ``m``
hypotheses of its family (the node pairs, nodes, DOFs or frequencies scanned), is worth it
when the extended BIC (Chen & Chen 2008; BIC plus the cost of naming one model among ``m``)
decreases:

``score = 2 N (J - J_e) / sigma^2 - k ln(2 N) - 2 ln m > 0``.

The ``ln m`` term is what keeps a scan of a thousand locations from "finding" one that merely
absorbs noise: the best of ``m`` pure-noise fits gains about ``2 ln m`` (the maximum of ``m``
chi-square variables of one degree of freedom).  Candidates are ranked by this score, so
that an effect with few parameters that explains the data wins over a flexible one that
merely absorbs error.

Significance test (nothing invented).  Ranking is not acceptance: the best candidate is
accepted only when the error it removes exceeds what the noise alone would remove by chance
in a search over that many candidates.  Under the null hypothesis (the model is right, the
residual is noise, complex Gaussian of variance ``sigma^2``, i.e. ``2N`` real observations of
variance ``sigma^2 / 2``), the least-squares reduction of a fit of ``k`` parameters is
``chi^2_k`` distributed once scaled: ``T = 2 N (J - J_e) / sigma^2 ~ chi^2(k)``.  For the
best of the ``M`` hypotheses of a step (all families together) the Bonferroni bound gives the
false-alarm probability ``p = min(1, M P(chi^2_k > T))``; the effect is accepted when ``p <
ALPHA`` (``ALPHA = 1e-3``), with ``sigma^2`` estimated from the data (second differences, above)
-- over ``N ~ 10^4..10^5`` entries its relative error is below 1%, so that the chi-square
(rather than an F) distribution is used.  See :func:`false_alarm`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtrc  # chi-square survival (scipy.stats costs seconds to import)

__all__ = ["ALPHA", "ResidualMap", "complex_residual", "cost", "ebic_score", "false_alarm",
           "log_ratio", "noise_floor", "noise_level", "ratio_cost", "residual_map"]

#: largest accepted false-alarm probability of a step (Bonferroni over its hypotheses)
ALPHA = 1e-3

#: ``ln 2``: median of an exponential variable of unit mean
_LN2 = float(np.log(2.0))


def complex_residual(H, Hd) -> np.ndarray:
    """``Log(H / Hd)``: the complex logLS residual (3.12), phase wrapped to ``(-pi, pi]``.

    Parameters
    ----------
    H : ndarray, shape (nf, ns, na)
        Predicted responses.
    Hd : ndarray, shape (nf, ns, na)
        Measured responses (non-zero).

    Returns
    -------
    ndarray, complex
    """
    return log_ratio(H / Hd)


def log_ratio(q) -> np.ndarray:
    """``Log(q)`` of a ratio ``q = H / Hd`` already formed, with the magnitude floored as
    :func:`complex_residual` does (``log |q| >= -50``).

    Parameters
    ----------
    q : ndarray, complex
        Ratio of predicted to measured responses.

    Returns
    -------
    ndarray, complex
    """
    out = np.empty(q.shape, complex)
    out.real, out.imag = _log_abs(q), np.arctan2(q.imag, q.real)
    return out


def _log_abs(q) -> np.ndarray:
    """``max(log |q|, -50)`` from ``|q|^2`` (no square root: the residual's hot spot)."""
    a = q.real * q.real
    a += q.imag * q.imag
    with np.errstate(divide="ignore"):
        np.log(a, out=a)
    a *= 0.5
    return np.maximum(a, -50.0, out=a)


def cost(H, Hd) -> float:
    """Complex logLS cost (3.12), ``mean |Log H - Log Hd|^2``.

    Parameters
    ----------
    H, Hd : ndarray, shape (nf, ns, na)
        Predicted and measured responses.

    Returns
    -------
    float
    """
    return ratio_cost(H / Hd)


def ratio_cost(q) -> float:
    """:func:`cost` of a ratio ``q = H / Hd`` already formed: ``mean |Log q|^2``, the same
    numbers as ``mean(r.real**2 + r.imag**2)`` of ``r = log_ratio(q)`` without forming ``r``.

    Parameters
    ----------
    q : ndarray, complex
        Ratio of predicted to measured responses.

    Returns
    -------
    float
    """
    a = _log_abs(q)
    p = np.arctan2(q.imag, q.real)
    a *= a
    p *= p
    a += p
    return float(np.mean(a))


def noise_level(r) -> float:
    """Noise variance of a residual from its second differences along frequency.

    Parameters
    ----------
    r : ndarray, shape (nf, ns, na), complex
        Residual ``Log(H / Hd)`` (at least 3 lines).

    Returns
    -------
    float
        ``median |r_{l+1} - 2 r_l + r_{l-1}|^2 / (6 ln 2)``, the expected ``|r|^2`` of white
        noise; 0 with fewer than 3 lines.
    """
    if r.shape[0] < 3:
        return 0.0
    d = r[2:] - 2.0 * r[1:-1] + r[:-2]
    return float(np.median(d.real**2 + d.imag**2) / (6.0 * _LN2))


def noise_floor(r, n_std: float = 3.0) -> float:
    """A lower estimate of the noise variance of a residual: what no smooth effect removes.

    The second-difference estimate :func:`noise_level` assumes independent lines; spectra
    estimated through a window correlate neighbouring lines (a Hann window by -2/3), which
    doubles it.  Second differences over every other line, ``r_{l+2} - 2 r_l + r_{l-2}``,
    have the variance ``(6 - 8 rho_2 + 2 rho_4) sigma^2``: unbiased when only neighbours are
    correlated, low when lines two apart correlate positively (the Hann window's 1/6).  The
    smaller of the two estimates, lowered by ``n_std`` standard deviations of a median of
    the differences (relative ``1 / (ln 2 sqrt(N / 3))``: neighbouring differences share
    lines).

    Parameters
    ----------
    r : ndarray, shape (nf, ns, na), complex
        Residual ``Log(H / Hd)``.
    n_std : float
        Standard deviations of the medians taken off.

    Returns
    -------
    float
        0 with fewer than 5 lines.
    """
    if r.shape[0] < 5:
        return 0.0
    d = r[4:] - 2.0 * r[2:-2] + r[:-4]
    lag2 = float(np.median(d.real**2 + d.imag**2) / (6.0 * _LN2))
    low = 1.0 - n_std / (_LN2 * np.sqrt(d.size / 3.0))
    return max(min(noise_level(r), lag2) * low, 0.0)


def ebic_score(J, J_new, sigma2, n_entries, k, m) -> float:
    """Extended-BIC gain of an effect: ``2 N (J - J_e) / sigma^2 - k ln(2N) - 2 ln m``.

    Parameters
    ----------
    J, J_new : float
        Cost before and after the effect.
    sigma2 : float
        Noise variance of the complex residual (expected ``|r|^2`` of noise).
    n_entries : int
        Number of complex residual entries ``N``.
    k : int
        Number of fitted parameters.
    m : int
        Number of hypotheses scanned in the effect's family.

    Returns
    -------
    float
        Positive when the effect is worth its parameters.
    """
    gain = 2.0 * n_entries * (J - J_new) / max(sigma2, 1e-300)
    return float(gain - k * np.log(2.0 * n_entries) - 2.0 * np.log(max(int(m), 1)))


def false_alarm(J, J_new, sigma2, n_entries, k, m) -> float:
    """Probability that noise alone removes ``J - J_new`` in a search over ``m`` hypotheses.

    Parameters
    ----------
    J, J_new : float
        Cost (3.12) before and after the effect.
    sigma2 : float
        Noise variance of the complex residual (expected ``|r|^2`` of noise).
    n_entries : int
        Number of complex residual entries ``N``.
    k : int
        Number of fitted parameters of the effect.
    m : int
        Number of hypotheses searched in the step (all families).

    Returns
    -------
    float
        The Bonferroni bound ``min(1, m P(chi^2_k > 2 N (J - J_new) / sigma^2))`` (module
        notes); 1 when the effect removes nothing.
    """
    T = 2.0 * n_entries * (J - J_new) / max(sigma2, 1e-300)
    if not T > 0:
        return 1.0
    with np.errstate(divide="ignore"):
        logp = float(np.log(chdtrc(max(int(k), 1), T))) + float(np.log(max(int(m), 1)))
    return float(np.exp(min(logp, 0.0)))


@dataclass(frozen=True, eq=False)
class ResidualMap:
    """Where a residual concentrates.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines (Hz).
    per_line : ndarray, shape (nf,)
        Mean ``|r|^2`` over channels at each line.
    per_channel : ndarray, shape (ns, na)
        Mean ``|r|^2`` over lines of each channel (the residual map).
    sensors, actuators : tuple of str
        Channel labels.
    cost : float
        Complex logLS cost (3.12).
    magnitude_cost : float
        Its log-magnitude part.
    quadratic : float
        Relative quadratic error (3.11), ``||H - Hd||_F / ||Hd||_F``.
    noise : float
        Noise variance estimated from the second differences.
    band : (float, float)
        Narrowest band holding half of the residual energy (Hz).
    band_share : float
        Fraction of the lines in that band.
    """

    freq: np.ndarray
    per_line: np.ndarray
    per_channel: np.ndarray
    sensors: tuple
    actuators: tuple
    cost: float
    magnitude_cost: float
    quadratic: float
    noise: float
    band: tuple
    band_share: float

    @property
    def phase_share(self) -> float:
        """Share of the cost carried by the phase."""
        return 1.0 - self.magnitude_cost / self.cost if self.cost > 0 else 0.0

    @property
    def worst_channel(self) -> tuple[int, int]:
        """``(sensor, actuator)`` indices of the channel with the largest residual."""
        i = int(np.argmax(self.per_channel))
        return divmod(i, self.per_channel.shape[1])

    def sensor_share(self) -> np.ndarray:
        """Share of the residual energy carried by each sensor, shape (ns,)."""
        tot = self.per_channel.sum()
        return self.per_channel.sum(axis=1) / tot if tot > 0 else np.zeros(len(self.sensors))

    def actuator_share(self) -> np.ndarray:
        """Share of the residual energy carried by each actuator, shape (na,)."""
        tot = self.per_channel.sum()
        return self.per_channel.sum(axis=0) / tot if tot > 0 else np.zeros(len(self.actuators))

    def edge_shares(self, fraction: float = 0.1) -> tuple[float, float]:
        """Shares of the residual energy in the lowest and highest ``fraction`` of the lines.

        Parameters
        ----------
        fraction : float
            Fraction of the lines at each end.

        Returns
        -------
        (float, float)
        """
        e = self.per_line
        tot = e.sum()
        k = max(1, round(fraction * e.size))
        if tot <= 0:
            return 0.0, 0.0
        return float(e[:k].sum() / tot), float(e[-k:].sum() / tot)

    def findings(self) -> list[str]:
        """Plain-language statements of where the residual concentrates.

        Returns
        -------
        list of str
        """
        out = []
        if self.cost <= 0:
            return ["the model reproduces the data exactly"]
        if self.noise > 0:
            out.append(f"cost {self.cost:.3g} is {self.cost / self.noise:.3g} times the noise "
                       f"level {self.noise:.3g} (second differences)")
        lo, hi = self.band
        out.append(f"half of the residual lies in {lo:.4g}-{hi:.4g} Hz "
                   f"({100 * self.band_share:.3g}% of the lines)")
        low, high = self.edge_shares()
        if low > 0.3:
            out.append(f"{100 * low:.3g}% at the lowest 10% of the lines (low-frequency "
                       "asymptote: residual mass, missing low modes)")
        if high > 0.3:
            out.append(f"{100 * high:.3g}% at the highest 10% of the lines (high-frequency "
                       "asymptote: residual flexibility, missing high modes)")
        if self.phase_share > 0.8:
            out.append(f"{100 * self.phase_share:.3g}% of the cost is phase (a delay or a "
                       "phase error of the measurement)")
        for share, labels, what in ((self.sensor_share(), self.sensors, "sensor"),
                                    (self.actuator_share(), self.actuators, "actuator")):
            j = int(np.argmax(share))
            if len(labels) > 2 and share[j] > 3.0 / len(labels) and share[j] > 0.25:
                out.append(f"{what} {labels[j]} carries {100 * share[j]:.3g}% of the residual")
        s, a = self.worst_channel
        out.append(f"worst channel {self.sensors[s]} / {self.actuators[a]}")
        return out


def _half_band(freq, e):
    """Narrowest contiguous set of lines holding half of ``e``: ((lo, hi) Hz, share)."""
    tot = e.sum()
    if tot <= 0 or e.size < 2:
        return (float(freq[0]), float(freq[-1])), 1.0
    c = np.concatenate([[0.0], np.cumsum(e)])
    # for each start i, the first end j with c[j] - c[i] >= tot / 2
    j = np.searchsorted(c, c[:-1] + 0.5 * tot)
    ok = j <= e.size
    i = np.flatnonzero(ok)
    width = j[ok] - i
    b = int(np.argmin(width))
    i0, i1 = int(i[b]), int(min(j[ok][b], e.size)) - 1
    return (float(freq[i0]), float(freq[i1])), float((i1 - i0 + 1) / e.size)


def residual_map(freq, H, Hd, sensors, actuators, noise: float | None = None) -> ResidualMap:
    """Residual analysis of a prediction against measured FRFs.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines (Hz).
    H, Hd : ndarray, shape (nf, ns, na)
        Predicted and measured responses (same quantity).
    sensors, actuators : sequence of str
        Channel labels.
    noise : float, optional
        The noise level to compare with (a diagnosis's own, so that its report quotes one);
        default estimated from this residual's second differences.

    Returns
    -------
    ResidualMap
    """
    r = complex_residual(H, Hd)
    a2 = r.real**2 + r.imag**2
    per_line = a2.mean(axis=(1, 2))
    band, share = _half_band(np.asarray(freq), per_line)
    return ResidualMap(np.asarray(freq, float), per_line, a2.mean(axis=0), tuple(sensors),
                       tuple(actuators), float(a2.mean()), float(np.mean(r.real**2)),
                       float(np.linalg.norm(H - Hd) / max(np.linalg.norm(Hd), 1e-300)),
                       noise_level(r) if noise is None else float(noise), band, share)
