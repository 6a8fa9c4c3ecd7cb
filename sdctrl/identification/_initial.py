"""Initial poles of the automatic selection of :func:`~sdctrl.identify` (thesis 3.2.1).

The thesis starts the pole search from an initial guess "determined through other
identification algorithms", from which computational poles are eliminated.  Two sources
are merged:

* the algebraic LSCF estimator (:mod:`~sdctrl.identification._lscf`) on the principal
  responses of the band: poles stable over three model orders, accurate (to the noise
  level) and usually all the modes of the band, close pairs included;
* peaks of the indicator functions (:func:`~sdctrl.identification._peaks.peak_candidates`)
  that no LSCF pole explains, and one peak just below and one just above the band when
  the FRF has lines there (out-of-band candidates).

The poles of every LSCF order computed are returned too, for a stabilisation diagram
(:func:`sdctrl.plot.stabilisation`).

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._lscf import lscf_poles, principal_responses, stable_poles

__all__ = ["initial_candidates", "lscf_candidates", "peak_set", "scaled"]

#: principal responses fitted by the LSCF estimator
N_PRINCIPAL = 8
#: order step of the LSCF orders and the highest order computed
ORDER_STEP, ORDER_MAX = 4, 64
#: lowest top order (that of ten modes, ``2 * 10 + 12``): the indicator functions of
#: single-reference data show one peak per close pair and none for weak modes, so
#: ``2 n_peaks + 12`` undercounts there (10 x 1 test set at 3% noise: 5 peaks for 8
#: modes, order 20, the partner of the close pair unstable; stable from order 28 in all
#: of seeds 0-7); the extra orders cost little, and a pole that is not a mode is still
#: judged by the significance test
ORDER_MIN = 32
#: orders a pole must be stable over
DEPTH = 3


def scaled(H: np.ndarray, e: int) -> np.ndarray:
    """``H * 2^-e`` (exact: a power of two only changes the exponents).

    Parameters
    ----------
    H : ndarray, complex
        Data.
    e : int
        Binary exponent.

    Returns
    -------
    ndarray
        ``H`` itself when ``e == 0``, else a scaled copy.
    """
    return H if e == 0 else np.ldexp(H.real, -e) + 1j * np.ldexp(H.imag, -e)


def peak_set(frf, freq, H, fband, e: int = 0):
    """Peak candidates in the band and just outside it.

    Parameters
    ----------
    frf : FRF
        All the measured lines (peaks just outside the band are looked for in them).
    freq : ndarray, shape (nf,)
        Lines of the band (Hz).
    H : ndarray, shape (nf, ns, na)
        FRF of the band, scaled by ``2^-e``.
    fband : (float, float)
        Band in Hz.
    e : int
        Binary exponent the data are scaled by (``frf.H`` is scaled likewise here).

    Returns
    -------
    w0 : ndarray
        Natural frequencies (rad/s).
    z0 : ndarray
        Damping ratios (half-power width).
    side : ndarray of int
        0 in band, -1 below, +1 above.
    """
    from sdctrl.identification._peaks import peak_candidates

    nf = freq.size
    f0, z0, _ = peak_candidates(freq, H, 4, 2.0, None) if nf >= 3 else ([], [], [])
    w0 = 2 * np.pi * np.asarray(f0, float)
    z0 = np.asarray(z0, float)
    side = np.zeros(w0.size, int)
    lo_extra = (frf.freq >= 0.75 * fband[0]) & (frf.freq < fband[0])
    hi_extra = (frf.freq > fband[1]) & (frf.freq <= 1.25 * fband[1])
    for sel, sd in ((lo_extra, -1), (hi_extra, 1)):
        if np.count_nonzero(sel) >= 5:
            fo, zo, so = peak_candidates(frf.freq[sel], scaled(frf.H[sel], e), 4, 2.0, None)
            if fo.size:
                i = np.argmax(so)
                w0 = np.append(w0, 2 * np.pi * fo[i])
                z0 = np.append(z0, zo[i])
                side = np.append(side, sd)
    return w0, z0, side


def lscf_candidates(freq, Y, fband, n_peaks: int, zeta_max: float):
    """Stable LSCF poles of the band (module notes) and the poles of every order.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines of the band (Hz).
    Y : ndarray, shape (2 nf, k)
        Stacked (compressed) data of the pole search.
    fband : (float, float)
        Band in Hz.
    n_peaks : int
        Number of in-band peak candidates (sets the model orders: the highest is
        ``2 n_peaks + 12``, at least :data:`ORDER_MIN`, at most 64 and below a quarter
        of the lines).
    zeta_max : float
        Largest damping ratio kept.

    Returns
    -------
    w, z : ndarray
        Natural frequencies (rad/s) and damping ratios of the stable poles.
    stabilisation : dict
        ``{"orders": ndarray of int, "poles": list of ndarray}`` (rad/s, every root of
        each order's denominator), the input of :func:`sdctrl.plot.stabilisation`.
    """
    nf = freq.size
    top = min(max(2 * n_peaks + 12, ORDER_MIN), ORDER_MAX, (nf - 1) // 4)
    top -= top % ORDER_STEP
    if top < 3 * ORDER_STEP:
        return np.zeros(0), np.zeros(0), {"orders": np.zeros(0, int), "poles": []}
    orders = np.arange(ORDER_STEP, top + 1, ORDER_STEP)
    poles = lscf_poles(freq, principal_responses(Y, N_PRINCIPAL), orders)
    w, z = stable_poles(poles, fband, zeta_max, depth=DEPTH)
    return w, z, {"orders": orders, "poles": poles}


def initial_candidates(w_l, z_l, w0, z0, side, df: float):
    """LSCF poles (in band) merged with the peak candidates no LSCF pole explains.

    A peak within 1.5 lines or a half-power bandwidth ``zeta w`` of an LSCF pole is the
    same mode (two poles on one mode would each look insignificant and both be dropped).

    Parameters
    ----------
    w_l, z_l : ndarray
        LSCF poles (rad/s, damping).
    w0, z0 : ndarray
        Peak candidates (rad/s, damping).
    side : ndarray of int
        Sides of the peak candidates (0 in band, -1 below, +1 above).
    df : float
        Line spacing (Hz).

    Returns
    -------
    w, z : ndarray
        Natural frequencies (rad/s) and damping ratios.
    side : ndarray of int
        0 in band, -1 below, +1 above.
    pending : ndarray of bool
        The in-band peaks no LSCF pole explains (fitted after the others).
    """
    if w_l.size == 0:
        return w0, z0, side, np.zeros(w0.size, bool)
    tol = np.maximum(2 * np.pi * 1.5 * df, z_l * w_l)
    near = np.any(np.abs(w0[:, None] - w_l[None, :]) <= tol[None, :], axis=1)
    extra = (side != 0) | ~near
    return (np.concatenate([w_l, w0[extra]]), np.concatenate([z_l, z0[extra]]),
            np.concatenate([np.zeros(w_l.size, int), side[extra]]),
            np.concatenate([np.zeros(w_l.size, bool), side[extra] == 0]))
