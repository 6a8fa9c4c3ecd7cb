"""Initial pole estimates from peaks of indicator functions (thesis 3.1.4, 3.2.1).

The thesis starts its pole search from "graphically picked" resonance peaks with a
realistic damping of 1%.  Here the peaks are picked automatically from

* the summed FRF ``sum_{s,a} |H_sa(f)|`` (global resonances), and
* the first few singular values ``sigma_1(f) >= sigma_2(f) >= ...`` of the matrix
  ``H(f)`` (ns x na) at every line, the complex mode indicator function (CMIF).

Two modes 1% apart, or a heavily damped mode next to a lightly damped one, appear as
separate peaks of ``sigma_2 .. sigma_4`` when the summed FRF shows only one; weakly
excited local modes stand out in the singular values as well.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.extrema import peaks_with_prominence
from sdctrl.identification._residues import pole_from_params

__all__ = ["indicator_functions", "initial_poles", "peak_candidates"]


def indicator_functions(H: np.ndarray, n_sv: int = 4) -> np.ndarray:
    """Summed FRF and the first ``n_sv`` singular values of ``H(f)`` per line.

    Parameters
    ----------
    H : ndarray, shape (nf, ns, na)
        Complex FRF array.
    n_sv : int
        Number of singular values kept (at most ``min(ns, na)``).

    Returns
    -------
    ndarray, shape (nf, 1 + r)
        Column 0 is ``sum |H|`` over sensors and actuators, then ``sigma_1 .. sigma_r``.
    """
    nf, ns, na = H.shape
    summed = np.abs(H).reshape(nf, -1).sum(axis=1)
    # singular values from the small Gram matrix (min(ns, na) square) at every line
    if na <= ns:
        G = np.einsum("fsa,fsb->fab", H.conj(), H)
    else:
        G = np.einsum("fsa,fta->fst", H, H.conj())
    ev = np.linalg.eigvalsh(G)[:, ::-1]
    sv = np.sqrt(np.clip(ev.real, 0, None))[:, :max(1, min(n_sv, ev.shape[1]))]
    return np.column_stack([summed, sv])


def _half_power_damping(f: np.ndarray, c: np.ndarray, i: int, default: float) -> float:
    """Damping from the half-power width of the peak ``c[i]`` (``zeta = df / 2 f``)."""
    target = c[i] / np.sqrt(2.0)
    nf = f.size
    width = []
    j = i
    while j > 0 and c[j] > target and c[j - 1] <= c[j] * 1.0001:
        j -= 1
    if c[j] <= target and j < i:
        t = (c[j + 1] - target) / (c[j + 1] - c[j])
        width.append(f[i] - (f[j + 1] - t * (f[j + 1] - f[j])))
    j = i
    while j < nf - 1 and c[j] > target and c[j + 1] <= c[j] * 1.0001:
        j += 1
    if c[j] <= target and j > i:
        t = (c[j - 1] - target) / (c[j - 1] - c[j])
        width.append((f[j - 1] + t * (f[j] - f[j - 1])) - f[i])
    if not width:
        return default
    bw = 2 * min(width) if len(width) == 1 else sum(width)
    return float(bw / (2 * f[i]))


def peak_candidates(freq: np.ndarray, H: np.ndarray, n_sv: int = 4, prominence: float = 2.0,
                    damping: float | None = 0.01):
    """Peaks of the indicator functions, merged across curves.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Frequencies in Hz.
    H : ndarray, shape (nf, ns, na)
        FRF array.
    n_sv : int
        Singular values searched for peaks.
    prominence : float
        Minimal peak prominence in dB.
    damping : float or None
        Damping given to every candidate; None estimates it from the half-power width.

    Returns
    -------
    f0 : ndarray
        Peak frequencies in Hz (parabolic interpolation of the log curve).
    zeta : ndarray
        Damping ratios.
    strength : ndarray
        Prominence in dB (used to rank candidates).
    """
    curves = indicator_functions(H, n_sv)
    nf = freq.size
    df = float(np.median(np.diff(freq))) if nf > 1 else 1.0
    found = []
    for ic in range(curves.shape[1]):
        c = curves[:, ic]
        if not np.any(c > 0):
            continue
        logc = 20 * np.log10(np.maximum(c, c.max() * 1e-300 + 1e-300))
        idx, proms = peaks_with_prominence(logc, prominence)    # scipy's find_peaks
        for i, prom in zip(idx, proms):
            y0, y1, y2 = logc[i - 1], logc[i], logc[i + 1]
            den = y0 - 2 * y1 + y2
            shift = 0.5 * (y0 - y2) / den if den < 0 else 0.0
            fi = float(np.interp(i + np.clip(shift, -0.5, 0.5), np.arange(nf), freq))
            zi = damping if damping is not None else _half_power_damping(freq, c, i, 0.01)
            # singular values 2.. rank slightly below sigma_1 and the summed curve
            found.append((fi, zi, float(prom) - (0.5 if ic > 1 else 0.0), ic))
    if not found:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    found.sort()
    tol = 1.5 * df
    groups = [[found[0]]]
    for item in found[1:]:
        if item[0] - groups[-1][0][0] <= tol:
            groups[-1].append(item)
        else:
            groups.append([item])
    f0, z0, st = [], [], []
    for g in groups:
        best = max(g, key=lambda t: t[2])
        f0.append(best[0])
        z0.append(best[1])
        st.append(best[2])
    f0, z0, st = np.array(f0), np.array(z0), np.array(st)
    if damping is None:
        zmin = 0.25 * df / (2 * f0)
        z0 = np.clip(z0, zmin, 0.05)
    return f0, z0, st


def initial_poles(frf, band=None, n: int | None = None, damping: float = 0.01,
                  n_sv: int = 4, prominence: float = 2.0) -> np.ndarray:
    """Initial pole guesses from peaks of the summed FRF and of the CMIF.

    Peaks of the summed amplitude ``sum |H_sa(f)|`` and of the first ``n_sv``
    singular values of ``H(f)`` are merged (peaks closer than 1.5 lines are one
    candidate), so that close modes (within 1%), a heavily damped mode beside a lightly
    damped one (seen in ``sigma_2 .. sigma_4``) and weakly excited local modes are
    proposed.  Each candidate gets the damping ``damping`` (1% by default, as in the
    thesis, 3.2.1).

    Parameters
    ----------
    frf : FRF
        Measured FRFs (any quantity: peaks are searched on the measured data).
    band : (float, float), optional
        Frequency band in Hz; the whole FRF by default.
    n : int, optional
        Keep only the ``n`` most prominent candidates.
    damping : float
        Damping ratio of every candidate, in (0, 1).
    n_sv : int
        Number of singular values of ``H(f)`` searched for peaks.
    prominence : float
        Minimal prominence of a peak, in dB.

    Returns
    -------
    ndarray of complex
        Poles in rad/s (upper half-plane), sorted by frequency.

    Examples
    --------
    >>> import sdctrl as sd
    >>> frf = sd.testbed_frf(n=400)
    >>> poles = sd.initial_poles(frf, band=(8, 60))
    >>> bool((poles.imag > 0).all())
    True
    """
    from sdctrl._lib.validate import check_band as _check_band
    from sdctrl.data._frf import FRF

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    if band is not None:
        frf = frf.band(*_check_band(band, "band"))
    if n is not None and (isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1):
        raise ValueError(f"n must be a positive integer or None, got {n!r}")
    if not (isinstance(damping, int | float) and 0 < damping < 1):
        raise ValueError(f"damping must be a ratio in (0, 1), got {damping!r}")
    if not isinstance(n_sv, int | np.integer) or n_sv < 1:
        raise ValueError(f"n_sv must be a positive integer, got {n_sv!r}")
    if not (isinstance(prominence, int | float) and 0 < prominence < np.inf):
        raise ValueError(f"prominence must be a positive finite number of dB, got {prominence!r}")
    if frf.freq.size < 3:
        raise ValueError(f"frf must have at least 3 frequency lines in the band, "
                         f"got {frf.freq.size}")
    f0, z0, st = peak_candidates(frf.freq, frf.H, int(n_sv), float(prominence), float(damping))
    if n is not None and f0.size > n:
        keep = np.sort(np.argsort(-st, kind="stable")[:n])
        f0, z0 = f0[keep], z0[keep]
    return pole_from_params(2 * np.pi * f0, z0)
