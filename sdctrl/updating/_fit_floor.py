"""Is the updated model at the noise floor of the test?  (issue 22: an update that stops
above it says so, and where the excess lies.)

The logLS cost (3.12) of a perfect model against noisy data is not zero: for relative
complex noise of standard deviation ``sigma`` on each line, ``ln|H (1 + sigma e)| - ln|H|
~ sigma Re(e)``, whose mean square is ``sigma^2 / 2``.  The noise is estimated from the data
alone, by second differences along frequency: ``H[k+1] - 2 H[k] + H[k-1]`` is pure noise
(variance ``6 sigma^2 |H|^2``) wherever the FRF is smooth on the line spacing, and the median
over lines and channels is robust to the few lines at sharp resonances where it is not.
On noise-free data the estimate is the curvature left at the line spacing (tiny), so any
model-structure error shows.

A final cost well above that floor means the parameters cannot explain the data: a local
minimum (see the pairing table: MAC after the update), a damping model that misses the
peak levels, a model error outside the parameters, or the update's reduced basis (modes to
``fmax``).  Where the excess lies tells the first three apart: the fraction of the squared
log error within two half-power bandwidths of the test modes (the peaks) against the rest;
the basis is tested directly (:func:`basis_limited`: the same parameters, modes to twice
``fmax``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.logratio import log_magnitude_ratio

__all__ = ["FLOOR_FACTOR", "FitFloor", "basis_limited", "fit_floor", "noise_floor"]

#: a final cost above this many times the noise floor is reported (and warned about)
FLOOR_FACTOR = 10.0


@dataclass(frozen=True, eq=False)
class FitFloor:
    """The final cost against the noise floor of the test.

    Parameters
    ----------
    noise_floor : float
        logLS cost (3.12) a perfect model would have against these data.
    ratio : float
        Final cost / noise floor.
    at_peaks : float
        Fraction of the excess squared log error within two half-power bandwidths of the
        test modes.
    text : str
        The verdict in words, with what to try.
    """

    noise_floor: float
    ratio: float
    at_peaks: float
    text: str

    @property
    def above(self) -> bool:
        """True when the final cost exceeds ``FLOOR_FACTOR`` times the noise floor."""
        return bool(self.ratio > FLOOR_FACTOR)


def noise_floor(H: np.ndarray) -> float:
    """logLS noise floor of FRF data ``H`` (nf, ns, na) from second differences.

    Parameters
    ----------
    H : ndarray, shape (nf, ...)
        Complex FRF on a uniform frequency grid (axis 0).

    Returns
    -------
    float
        ``sigma^2 / 2`` with ``sigma^2 = median(|d2 H|^2 / (6 |H|^2)) / ln 2`` (the median of
        an exponential variable is ``ln 2`` times its mean); NaN with fewer than 3 lines.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> H = np.ones((4000, 1, 1)) * (1 + 0.01 * (rng.standard_normal((4000, 1, 1))
    ...     + 1j * rng.standard_normal((4000, 1, 1))) / np.sqrt(2))
    >>> round(float(noise_floor(H) / 0.5e-4), 1)
    1.0
    """
    H = np.asarray(H)
    if H.shape[0] < 3:
        return float("nan")
    d2 = H[2:] - 2 * H[1:-1] + H[:-2]
    mag = np.abs(H[1:-1]) ** 2
    ok = mag > 0
    if not np.any(ok):
        return float("nan")
    s2 = float(np.median(np.abs(d2[ok]) ** 2 / (6 * mag[ok]))) / np.log(2)
    return 0.5 * s2


def fit_floor(cost: float, freq, H_model, H_data, test_hz, test_zeta) -> FitFloor:
    """The final cost against the noise floor, and where the excess lies.

    Parameters
    ----------
    cost : float
        Final logLS cost of the model.
    freq : ndarray, shape (nf,)
        Lines (Hz) of the data.
    H_model, H_data : ndarray, shape (nf, ns, na)
        The model's and the data's FRFs (same quantity).
    test_hz, test_zeta : ndarray, shape (m,)
        Frequencies and damping ratios of the test modes (for the peak bands).

    Returns
    -------
    FitFloor
    """
    floor = noise_floor(H_data)
    ratio = cost / floor if floor > 0 else float("inf")
    d2 = np.mean(log_magnitude_ratio(H_model, H_data) ** 2,
                 axis=tuple(range(1, np.ndim(H_data))))
    excess = np.clip(d2 - floor, 0, None)
    near = np.zeros(freq.shape, bool)
    for f0, z in zip(np.atleast_1d(test_hz), np.atleast_1d(test_zeta)):
        half = 2 * max(float(z), 1e-4) * f0           # two half-power bandwidths
        near |= np.abs(freq - f0) <= max(half, 1.5 * _spacing(freq))
    total = float(excess.sum())
    at_peaks = float(excess[near].sum() / total) if total > 0 else 0.0
    return FitFloor(float(floor), float(ratio), at_peaks, _verdict(cost, floor, ratio,
                                                                   at_peaks))


def _spacing(freq) -> float:
    return float(np.median(np.diff(freq))) if freq.size > 1 else 0.0


def _verdict(cost, floor, ratio, at_peaks) -> str:
    if not ratio > FLOOR_FACTOR:
        return (f"at the noise floor (logLS {cost:.3g}, {ratio:.1f}x the floor {floor:.2g} "
                "estimated from the data)")
    where = (f"{at_peaks:.0%} of the excess lies at the resonances: the damping model misses "
             "the peak levels (try damping='data' or an identified model as damping=)"
             if at_peaks >= 0.5 else
             f"{1 - at_peaks:.0%} of the excess lies away from the resonances: a local minimum "
             "(check the MAC after the update in the pairing table; try strategy='logls' from "
             "other values) or a model error the parameters cannot reach (add parameters)")
    return (f"{ratio:.0f}x above the noise floor (logLS {cost:.3g}, floor {floor:.2g} "
            f"estimated from the data): {where}")


def basis_limited(fit: FitFloor, cost: float, fmax: float, richer: float) -> FitFloor:
    """``fit`` with its verdict on the reduced basis: when the same parameters on a basis
    with modes to ``2 fmax`` give a cost ``richer`` below half the final one, the basis (not
    the parameters) limits the fit (4.23: the truncated modes' dynamics are missing).

    Parameters
    ----------
    fit : FitFloor
        The verdict of :func:`fit_floor`.
    cost : float
        The final cost.
    fmax : float
        Highest frequency (Hz) of the normal modes of the update's basis.
    richer : float
        The cost of the same parameters with modes to ``2 fmax``.

    Returns
    -------
    FitFloor
    """
    if not richer < 0.5 * cost:
        return fit
    text = (f"{fit.ratio:.0f}x above the noise floor (logLS {cost:.3g}, floor "
            f"{fit.noise_floor:.2g} estimated from the data): the reduced basis limits the "
            f"fit -- with normal modes to {2 * fmax:.4g} Hz instead of {fmax:.4g} Hz the same "
            f"parameters give {richer:.3g}; pass fmax={2 * fmax:.4g} (or more)")
    return FitFloor(fit.noise_floor, fit.ratio, fit.at_peaks, text)
