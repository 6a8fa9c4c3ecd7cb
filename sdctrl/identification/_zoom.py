"""Close modes hidden under a fitted pole: the local rank test and a zoomed LSCF (3.2.1).

A residual scan (:mod:`~sdctrl.identification._missed_scan`) compares each trial pole with
a noise level estimated from the residual; next to a pole that stands for several close
modes, the residual of the missed ones is taken for noise (it is the residual), and a mode
closer than a line to a fitted one has a trial basis nearly collinear with it.  The
thesis's own test applies instead: a single mode's contribution is a dyad (3.20), so the
number of modes near a frequency is the rank of the multi-channel FRF over the lines
there, ``[H(w_k)]`` stacked (lines x channels, 3.21-3.22 applied to the data rather than
to one residue).  Over a window of lines around each in-band pole:

* the complex data block ``H_W`` (``L`` lines x ``k`` compressed channels), its lines and
  channels scaled by a separable fit of the current fit's noise field (diagonal scalings:
  the rank is unchanged), has squared singular values ``s_i^2``; the noise scale is their
  median over the Marchenko-Pastur median (the median is the noise's while the modes are
  fewer than half the lines, whatever the residual of the current fit, which holds the
  missed modes themselves), and each mode gives at least one value above twice the
  Marchenko-Pastur edge ``sigma^2 (sqrt(L) + sqrt(k))^2``, the smooth contribution of the
  modes outside the window one more; so the data show ``rank - 1`` modes there.  Only
  when that exceeds the poles fitted in the window is the window zoomed into (a
  scale-free count: no threshold depends on the structure).  Windows are centred on the
  in-band poles and on the frequencies rejected before (a pole standing for several close
  modes may have been removed as not significant, the residual of the others taken for
  noise), ``max(20 lines, 5 zeta f)`` on each side;
* the zoom: an LSCF estimator (:mod:`~sdctrl.identification._lscf`) on the window's lines
  alone (its arc mapped on the window, so close modes are far apart on it), orders up to
  ``2 rank + 4``, poles stable over three orders; those no fitted pole explains are
  candidates (each fitted pole explains the nearest zoomed one within half a line or a
  third of its half-power bandwidth, one only: a pole standing for two modes explains
  one of them).

The candidates are then fitted, the fitted poles of their window searched with them, and
judged like any other by the significance test of
:class:`~sdctrl.identification._selection.AutoSelection` after their fit (whose noise no
longer holds their own residual).

The same count keeps a pole that stands for several close modes: judged against a noise
field that holds the residual of the modes it does not fit, such a pole can look
insignificant (the cluster of the testbed family fitted by one pole at 1% noise, 0.97
times its threshold: removed, the cluster was lost, 1 of 5 modes found).  An in-band
pole alone in its window, where the data show at least one mode (a local rank of two or
more: one mode and the smooth contribution of those outside), is not removed as
insignificant (:func:`sole_poles`).

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.identification._lscf import lscf_poles, principal_responses, stable_poles

__all__ = ["ZoomWindow", "local_rank", "mp_median", "sole_poles", "windows",
           "zoom_candidates"]

#: half-width of a window in lines, and in half-power bandwidths ``zeta f`` of its pole
HALF_LINES, HALF_BANDWIDTHS = 20, 5
#: principal responses of a zoomed LSCF
N_PRINCIPAL = 8
#: orders a zoomed pole must be stable over
DEPTH = 3


@dataclass(frozen=True, eq=False)
class ZoomWindow:
    """A window of lines around in-band poles: ``lines`` (indices into the band's lines)
    and the frequencies (Hz) of the poles fitted in it."""

    lines: np.ndarray
    poles: np.ndarray


def windows(freq, f_centres, z_centres, f_poles) -> list[ZoomWindow]:
    """Windows of lines around the in-band poles, overlapping ones merged.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines of the band (Hz), uniform or not.
    f_centres, z_centres : ndarray
        Frequencies (Hz) and damping ratios the windows are centred on.
    f_poles : ndarray
        Frequencies (Hz) of the in-band poles (counted in each window).

    Returns
    -------
    list of ZoomWindow
    """
    df = float(np.median(np.diff(freq)))
    spans = sorted((f - max(HALF_LINES * df, HALF_BANDWIDTHS * z * f),
                    f + max(HALF_LINES * df, HALF_BANDWIDTHS * z * f)) for f, z in
                   zip(f_centres, z_centres))
    merged = []
    for lo, hi in spans:
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    out = []
    for lo, hi in merged:
        lines = np.flatnonzero((freq >= lo) & (freq <= hi))
        f_poles = np.asarray(f_poles)
        inside = f_poles[(f_poles >= lo) & (f_poles <= hi)]
        out.append(ZoomWindow(lines, inside))
    return out


def _unexplained(f, z, fitted, df) -> list:
    """Zoomed poles ``(f Hz, z)`` that no fitted pole explains: each fitted pole explains
    the nearest zoomed one within half a line or a third of its half-power bandwidth, one
    only (a pole standing for two close modes explains one of them)."""
    left = list(range(f.size))
    for fp in fitted:
        near = [i for i in left if abs(f[i] - fp) <= max(0.5 * df, z[i] * f[i] / 3)]
        if near:
            left.remove(min(near, key=lambda i: abs(f[i] - fp)))
    return [(float(f[i]), float(z[i])) for i in left]


def mp_median(y: float) -> float:
    """Median of the Marchenko-Pastur law of ratio ``y = m/n <= 1`` (unit variance): the
    median eigenvalue of ``X X^H / n`` for an ``m x n`` matrix of independent unit
    complex noise, within ``[(1 - sqrt y)^2, (1 + sqrt y)^2]``.

    Parameters
    ----------
    y : float
        Aspect ratio, in (0, 1].

    Returns
    -------
    float
    """
    a, b = (1 - np.sqrt(y)) ** 2, (1 + np.sqrt(y)) ** 2
    # x = a + (b - a)(1 - cos t)/2: the density times dx is smooth in t (also for y = 1,
    # whose density diverges at 0)
    t = np.linspace(0.0, np.pi, 4001)
    x = a + 0.5 * (b - a) * (1 - np.cos(t))
    g = (0.5 * (b - a) * np.sin(t)) ** 2 / (2 * np.pi * y * np.maximum(x, 1e-300))
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t))])
    return float(np.interp(0.5, cdf / cdf[-1], x))


def local_rank(Y, sig2, lines, margin: float = 2.0) -> int:
    """Number of singular values of the complex data block over ``lines`` above the
    Marchenko-Pastur edge of its noise (module notes).

    The lines and the columns are scaled by a separable fit of the noise field over the
    window (diagonal scalings on both sides: the rank is unchanged, the noise of unequal
    lines and channels made alike); the noise scale is
    then the median eigenvalue over its Marchenko-Pastur median (the median is the
    noise's as long as the modes are fewer than half the lines), so the count does not
    depend on the residual of the current fit, which holds the missed modes themselves.

    Parameters
    ----------
    Y : ndarray, shape (2 nf, k)
        Stacked data ``[Re H; Im H]`` (compressed channels).
    sig2 : ndarray, shape (nf, k)
        Noise variance ``E|n|^2`` per line and column (the current fit's noise field).
    lines : ndarray of int
        The window.
    margin : float
        Factor on the edge a singular value squared must exceed.

    Returns
    -------
    int
    """
    nf = Y.shape[0] // 2
    s2w = sig2[lines] + 1e-300
    rows = np.mean(s2w, axis=1) / np.mean(s2w)                # separable noise level
    cols = np.mean(s2w / rows[:, None], axis=0)
    Hw = (Y[lines] + 1j * Y[nf + lines]) / np.sqrt(rows[:, None] * cols[None, :])
    m, n = sorted(Hw.shape)
    s2 = np.linalg.svd(Hw, compute_uv=False) ** 2
    sigma2 = float(np.median(s2)) / (n * mp_median(m / n))
    edge = sigma2 * (np.sqrt(m) + np.sqrt(n)) ** 2
    return int(np.count_nonzero(s2 > margin * edge))


def sole_poles(freq, Y, sig2, f_poles, z_poles, in_band, check) -> np.ndarray:
    """Which in-band poles stand alone in a window where the data show modes (module
    notes): the last pole of a window is not removed as insignificant.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines of the band (Hz).
    Y : ndarray, shape (2 nf, k)
        Stacked data of the pole search.
    sig2 : ndarray, shape (nf, k)
        Noise field of the current fit.
    f_poles, z_poles : ndarray, shape (n,)
        Frequencies (Hz) and damping ratios of the poles.
    in_band, check : ndarray of bool, shape (n,)
        The in-band poles (the only ones a window counts), and the poles to check.

    Returns
    -------
    ndarray of bool, shape (n,)
        True for a checked in-band pole alone in its window (:func:`windows`, at least
        12 lines) whose local rank (:func:`local_rank`) is two or more.
    """
    out = np.zeros(f_poles.size, bool)
    for j in np.flatnonzero(check & in_band):
        win = windows(freq, f_poles[j:j + 1], z_poles[j:j + 1], f_poles[in_band])[0]
        out[j] = (win.poles.size == 1 and win.lines.size >= 12
                  and local_rank(Y, sig2, win.lines) >= 2)
    return out


def zoom_candidates(freq, Y, sig2, f_poles, z_poles, zeta_max: float, rejected=()):
    """Poles of close modes the fitted in-band poles do not explain (module notes).

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines of the band (Hz).
    Y : ndarray, shape (2 nf, k)
        Stacked data of the pole search.
    sig2 : ndarray, shape (nf, k)
        Noise field of the current fit.
    f_poles, z_poles : ndarray
        Frequencies (Hz) and damping ratios of the in-band poles.
    zeta_max : float
        Largest damping ratio of a candidate.
    rejected : sequence of float
        Frequencies (Hz) of poles rejected or removed before: windows are centred there
        too (a pole standing for several close modes may have been removed as not
        significant, the residual of the others taken for noise).

    Returns
    -------
    candidates : list of (float, float)
        ``(frequency Hz, damping ratio)`` of the candidates.
    spans : list of (float, float)
        The windows (Hz) they were found in.
    """
    df = float(np.median(np.diff(freq)))
    rejected = np.asarray([t for t in rejected if freq[0] <= t <= freq[-1]], float)
    out, spans = [], []
    for win in windows(freq, np.concatenate([f_poles, rejected]),
                       np.concatenate([z_poles, np.zeros(rejected.size)]), f_poles):
        L = win.lines.size
        rank = local_rank(Y, sig2, win.lines)
        if rank - 1 <= win.poles.size or L < 12:
            continue
        top = min(2 * rank + 4, (L - 1) // 2)
        if top < DEPTH + 1:
            continue
        fw = freq[win.lines]
        rows = np.concatenate([win.lines, Y.shape[0] // 2 + win.lines])
        poles = lscf_poles(fw, principal_responses(Y[rows], N_PRINCIPAL),
                           np.arange(2, top + 1))
        w, z = stable_poles(poles, (fw[0], fw[-1]), zeta_max, depth=DEPTH)
        f = w / (2 * np.pi)
        new = _unexplained(f, z, win.poles, df)
        if new:
            out += new
            spans.append((float(fw[0]), float(fw[-1])))
    return out, spans
