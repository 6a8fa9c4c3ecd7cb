"""Complex-mode identification, :func:`identify` (thesis 3.2.1).

All sensors and actuators are fitted together with a common set of poles.  For given
poles the residues and the asymptotic terms solve the linear least-squares problem
(3.15)-(3.16) (:mod:`~sdctrl.identification._residues`); the poles are updated by the
gradient (3.19) or by variable projection (:mod:`~sdctrl.identification._search`) on data
compressed to their dominant column space (:mod:`~sdctrl.identification._compression`);
with no poles given and noise independent between lines (no recorded window), each
channel divided by its noise level first (:func:`~sdctrl.identification._compression.
channel_weights`: a mode seen on a few quiet channels is not lost in the noise of the
loud ones; the residues, solved per channel, do not change).
With no poles given, the initial poles are the stable poles of an algebraic LSCF
estimator merged with peak candidates (:mod:`~sdctrl.identification._initial`), and the
automatic selection (:mod:`~sdctrl.identification._selection`) adds, removes and tries
poles, judged by a heteroscedastic significance test (:mod:`~sdctrl.identification._noise`)
and a residual scan (:mod:`~sdctrl.identification._missed_scan`).  The final residues are solved
on the full data.

Scale: the data are scaled by a power of two (exact) when their largest entry lies
outside ``[2^-300, 2^300]``, and the residues scaled back, so any scale a float holds
gives the same poles.

Threads: the whole call runs on one BLAS thread (:mod:`sdctrl._lib.threads`), a context
scoped to the call and restored after.  Progress: one bar per call
(:mod:`sdctrl._lib.progress`, ``sdctrl.config.progress``).
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl._lib.progress import progress_bar
from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import QUANTITY_POWER, as_array
from sdctrl.identification._compression import channel_weights, compressed_data
from sdctrl.identification._far_terms import CollocatedResidues
from sdctrl.identification._final_fit import FitSpec, final_model
from sdctrl.identification._initial import (
    initial_candidates,
    lscf_candidates,
    peak_set,
    scaled,
)
from sdctrl.identification._line_weights import line_weights
from sdctrl.identification._residues import n_per_pole
from sdctrl.identification._search import ZETA_MAX, ZETA_MIN, PoleProblem, search_poles
from sdctrl.identification._rules import selection_rules
from sdctrl.identification._selection import AutoSelection
from sdctrl.identification._quality import assessed

__all__ = ["IdentificationWarning", "identify"]


#: default weighting of the lines (:func:`identify`; "level" measured, not yet the default:
#: module notes of :mod:`~sdctrl.identification._line_weights`)
WEIGHTING = "none"


class IdentificationWarning(UserWarning):
    """Numerical trouble during identification (ill-conditioning, no convergence, ...)."""


def identify(frf, poles=None, band=None, *, model: str = "complex", optimizer: str = "varpro",
             in_band=None, asymptotic: bool = True, compress_rank: int | None = None,
             max_iter: int | None = None, tol: float = 1e-10, min_bandwidth: float = 0.5,
             zeta_max: float = 0.25, significance: float = 2.0, seed: int | None = 0,
             weighting: str = WEIGHTING, progress: bool | None = None):
    """Identify a complex-mode model (3.7) from measured FRFs (thesis 3.2.1).

    All sensors and actuators are fitted together with a common set of poles.  For
    given poles the residues ``R_j`` and the real asymptotic terms ``E`` (residual
    flexibility) and ``F/s^2`` (residual mass) solve the linear least-squares problem
    (3.15)-(3.16) by QR; the poles are updated by the gradient (3.19) or by variable
    projection (see :mod:`sdctrl.identification._search`).  The measured quantity is
    accounted for in the basis, so residues, ``E`` and ``F`` describe the
    displacement/force response.

    Parameters
    ----------
    frf : FRF
        Measured FRFs (displacement, velocity or acceleration per unit force).  The fit is
        the same for ``frf`` and ``frf.transpose()`` (common poles, full residue matrices),
        so a roving-hammer survey (few sensors, many hit points) is fitted as it is; the
        model keeps the test's orientation and :func:`~sdctrl.normal_modes` transposes by
        itself where it needs more sensors than modes.
    poles : array_like of complex, optional
        Initial poles in rad/s (Im > 0, Re < 0).  When None, the poles are found
        automatically: the poles of an LSCF polynomial model of a few principal
        responses that are stable over three model orders, merged with the
        :func:`~sdctrl.identification.initial_poles` candidates no LSCF pole explains
        (peaks of the summed FRF and of the first singular values of ``H(f)``, damping
        from the half-power width); then rounds of removing poles that do not converge,
        fit noise, are fillers or are not significant (once out-of-band poles just below
        and above the band were tried), adding out-of-band poles, and adding poles
        at residual peaks (missed modes).
        Out-of-band poles (issue 22): the tails of modes outside the band that the
        asymptotic terms ``E``, ``F/s^2`` of the complex-mode model (3.7) do not carry
        are absorbed by poles held within a factor 4 of the band edges, one per side
        and pass, added while each new one is significant, i.e. while the residual
        near the band edges stays above the noise.  The rule is the significance test
        of 3.2.1 with the noise estimated from the data: for an out-of-band pole, the
        lower of the residual's running-median level and the level of its second
        differences along the lines (equal for noise independent between lines, far
        below for the smooth tail of a mode, which is no noise); in-band poles meet the
        running-median level alone.  An FRF measured through an exponential window
        (``frf.exponential_tau``) has noise correlated between lines
        (``c_k = 1/(1 + i pi k tau df)``, 0.8 between neighbours), which second
        differences take for signal: there one out-of-band pole per side is tried,
        against the direct level (with the second-difference level, a roving-hammer
        survey's band filled with poles fitting the correlated noise; counting the
        correlation in the test instead merged a blade pair of the cluster's survey and
        missed a mode of real hammer data).  No threshold depends on the structure.
        Close modes (unwindowed data): a frequency rejected by the residual scan is retried
        once the model has changed; where the rank of the multi-channel data over the
        lines around the in-band poles (a mode is a dyad, 3.20-3.22; counted against the
        Marchenko-Pastur edge of the window's own noise) exceeds the poles fitted there,
        an LSCF zoomed on those lines proposes the missing ones (modes closer than the
        line spacing, :mod:`~sdctrl.identification._zoom`).  The rules are chosen once
        from the data (:func:`~sdctrl.identification._rules.selection_rules`).
        The search stops when the fit is numerically exact, or after a round whose
        residual-peak candidates were all rejected.
    band : (float, float), optional
        Frequency band in Hz (default: all lines of ``frf``).  Only the lines of the band
        are used: ``identify(frf, band=B)`` and ``identify(frf.band(*B))`` give the same
        poles and residues (the model's ``band`` is ``B`` in the first, the span of the
        lines in the second).  Modes just outside the band are still looked for (out-of-band
        poles, ``in_band`` False) from their tails in the band.
    model : {"complex", "real"}
        Complex-mode parametrisation (3.7), or the real-mode one (3.9) (proportional
        damping, purely imaginary residues) for comparison.
    optimizer : {"varpro", "gradient", "none"}
        Pole update: variable projection (3.2.1) by a bounded trust-region method (the
        bounds, scaling and stopping tests of ``scipy.optimize.least_squares``), the
        thesis sign-gradient with per-parameter step halving (3.19), or none (residues
        of the given poles only).
    in_band : array_like of bool, optional
        For given ``poles``: which are in-band poles (default: those whose frequency lies
        in the band).  Out-of-band poles are held outside the band by bounds.
    asymptotic : bool
        Fit the asymptotic terms ``E`` and ``F/s^2``.
    compress_rank : int, optional
        Rank of the real basis the stacked data are compressed to for the pole search
        (default ``p + 16`` with ``p`` the number of basis functions of the initial
        poles plus six, at least 40);
        0 disables compression.
    max_iter : int, optional
        Maximum function evaluations (varpro, default 200) or iterations (gradient,
        default 2000) per pole search.
    tol : float
        Relative tolerance of the pole search.
    min_bandwidth : float
        Poles whose half-power bandwidth ``2 zeta f`` is below this fraction of the line
        spacing are rejected as noise fitting (automatic mode); such a peak is resolved
        by fewer than two lines and cannot be told from noise, unless (in band) the
        lines on its flanks determine its damping: standard deviation of ``ln zeta``
        from the noise (3.56) below 0.5, i.e. a damping more than two standard
        deviations above zero (a lightly damped mode well above the noise).
    zeta_max : float
        In-band poles with a larger damping ratio are rejected as fillers, and stable LSCF
        poles above it are not proposed (automatic mode).  Default 0.25: discrete dampers
        give real structures modes of 10-20% damping, while the fillers (poles fitted to
        the residual's trends) end at the search's damping bound, 0.6 (at 0.1 a mode damped
        10.1% was never proposed and the residual it left pulled the other poles to their
        bounds, ``tests/test_identify_damped_modes.py``).
    significance : float
        Multiplier of the noise threshold a pole's contribution must exceed to be kept
        (automatic mode); the threshold is the 1e-3/nf quantile of the cost change of a
        pole fitting pure noise, with a heteroscedastic noise level estimated locally
        from the residual (and the coherence when ``frf.coherence`` is given), see
        :mod:`sdctrl.identification._noise`.
    seed : int, optional
        Seed of the randomised range finder (results are deterministic given a seed).
    weighting : {"none", "level"}
        Weight of each line in the fit: ``"none"`` (every line alike: the lines at
        resonances dominate), or ``"level"``, the inverse of its level across the channels
        (the least squares become the logLS cost 3.12 linearised, the maximum-likelihood
        fit of noise relative to the response; :mod:`~sdctrl.identification._line_weights`),
        applied to data whose noise is independent between lines (not through an
        exponential window).  What was applied: ``cm.search.weighting``.
    progress : bool, optional
        Show a progress bar; None (default) follows ``sdctrl.config.progress`` (bars only
        on a terminal or in a notebook).

    Returns
    -------
    ComplexModeModel
        Poles sorted by frequency, displacement residues, ``E``, ``F``, ``in_band``,
        ``exponential_tau`` (data with an exponential window, ``frf.exponential_tau``: the
        poles are corrected for it, ``real += 1/tau``, so the damping is the structure's),
        ``cost`` (relative FRF error ``||H_fit - H||_F / ||H||_F`` in the band) and
        ``search`` (optimiser, evaluations, convergence, compression rank,
        interruption), ``warnings`` and, in automatic mode, ``stabilisation``: the LSCF
        poles of every order computed (``st.orders``, ``st.poles``), drawn by
        ``sd.plot.stabilisation(st.poles, frf, orders=st.orders)``; ``info`` keeps the
        selection log.

    Raises
    ------
    ValueError
        Empty band, fewer frequency lines than parameters, non-finite, unstable or
        lower half-plane poles, NaN in the data, unknown options; in automatic mode,
        data without a significant resonance in the band ("no mode found in the
        band", e.g. a constant FRF or white noise).

    Warns
    -----
    IdentificationWarning
        Ill-conditioned basis, pole search not converged, poles at a bound, automatic
        selection stopped or interrupted (also listed in ``warnings`` of the model); a fit
        error above 10%, or above 3 times the error the data's noise alone would leave
        (coherence, 3.59; else the residual's second differences, if noise-like), with
        where it lies and what to try; in-band poles forming multiplets of a drifting mode.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> f = np.linspace(5, 15, 400)
    >>> lam = -0.01 * 2 * np.pi * 10 + 2j * np.pi * 10
    >>> s = 2j * np.pi * f
    >>> H = 1 / (s - lam) + 1 / (s - lam.conjugate())
    >>> cm = sd.identify(sd.FRF(f, 1j * H), progress=False)
    >>> bool(abs(cm.frequency[0] - 10.0005) < 1e-3)
    True
    """
    max_iter = _check_options(frf, model, optimizer, max_iter, tol, min_bandwidth, zeta_max,
                              significance)
    if weighting not in ("level", "none"):
        raise ValueError(f"weighting must be 'level' or 'none', got {weighting!r}")
    fband, data, shown = _band(frf, band)
    nf = data.freq.size
    asym = (True, True) if asymptotic else (False, False)
    npp = n_per_pole(model)
    auto = poles is None
    with single_thread():                     # one BLAS policy for the whole call
        e = _exponent(data.H)
        Hm = scaled(data.H.reshape(nf, -1), e)
        if auto:
            w0, z0, side = peak_set(data, data.freq, Hm.reshape(data.H.shape), fband, e)
        else:
            w0, z0, side = _given_poles(poles, in_band, fband)
        _check_lines(nf, (npp + 2) * w0.size + sum(asym), w0.size)
        p_guess = npp * (w0.size + 6) + sum(asym)
        rank = max(p_guess + 16, 40) if compress_rank is None else int(compress_rank)
        rules = selection_rules(data)
        cw, lw = _weights(Hm, rules, auto, weighting)
        Y, V, rank, residual = _searched_data(Hm, cw, lw, rank, seed)
        info = {"optimizer": optimizer, "model": model, "asymptotic": bool(asymptotic),
                "compress_rank": int(rank), "lines": int(nf), "channels": int(Hm.shape[1])}
        if V is not None:
            info["compression_residual"] = residual
        if auto:
            merged = _algebraic(data.freq, Y, fband, (w0, z0, side), zeta_max, info)
            if 2 * nf >= (npp + 2) * merged[0].size + sum(asym):   # else: the peaks only
                w0, z0, side, pending = merged
            else:
                pending = np.zeros(w0.size, bool)
        messages = []
        opts = (fband, optimizer, max_iter, tol)
        bar = progress_bar(desc="identify", unit="eval", enabled=progress)
        try:
            prob = PoleProblem(Y, 2j * np.pi * data.freq, QUANTITY_POWER[data.quantity],
                               model, asym, bar, lw)
            if auto:
                sel = AutoSelection(prob, data.freq, fband, optimizer, max_iter, tol,
                                    min_bandwidth, zeta_max, significance, messages.append,
                                    _noise_shape(data, Hm, V, cw, lw), rules=rules,
                                    collocated=CollocatedResidues.of(data, Hm, prob))
                w, z, side = _select(sel, (w0, z0, side, pending), bar, info, messages)
                if not np.any(side == 0):
                    raise ValueError(f"frf: no mode found in the band {fband[0]:g}-"
                                     f"{fband[1]:g} Hz (no significant resonance in the "
                                     "data; give poles= to fit chosen poles anyway)")
            else:
                w, z = _given_search(prob, w0, z0, side, opts, info, messages)
            info["nfev"] = prob.nfev
        finally:
            bar.close()
        cm = final_model(data, shown, Hm, (w, z, side), FitSpec(model, asym, lw), info,
                         messages, e)
        cm, quality = assessed(cm, data)          # against the data as measured (windowed)
        cm = _window_corrected(cm, data.exponential_tau, messages)
    for msg in messages + quality:
        warnings.warn(msg, IdentificationWarning, stacklevel=2)
    return cm


def _exponent(H) -> int:
    """Binary exponent ``e`` the data are scaled by (``H 2^-e``, exact) so that their
    largest entry is near 1 when it lies outside ``[2^-300, 2^300]`` (identification does
    not depend on the scale of ``H``: squares of ``1e160`` or ``1e-160`` would overflow or
    underflow); 0 otherwise."""
    big = float(np.max(np.abs(H))) if H.size else 0.0
    if big == 0:
        raise ValueError("frf.H is identically zero in the band")
    e = int(np.frexp(big)[1])
    return e if abs(e) > 300 else 0


def _check_lines(nf, n_par, n_poles):
    if 2 * nf < n_par or nf < 3:
        raise ValueError(f"frf: the band has {nf} frequency lines, fewer than needed for the "
                         f"{n_par} real parameters per channel of {n_poles} poles "
                         f"(need 2 * n_lines >= parameters)")


def _algebraic(freq, Y, fband, peaks, zeta_max, info):
    """Peak candidates merged with the stable LSCF poles (and which peaks are pending);
    the LSCF poles of every order go to ``info["stabilisation"]`` (then the model's field)."""
    w0, z0, side = peaks
    w_l, z_l, stab = lscf_candidates(freq, Y, fband, int(np.count_nonzero(side == 0)),
                                     zeta_max)
    info["stabilisation"] = stab
    df = float(np.median(np.diff(freq))) if freq.size > 1 else 1.0
    return initial_candidates(w_l, z_l, w0, z0, side, df)


def _check_options(frf, model, optimizer, max_iter, tol, min_bandwidth, zeta_max,
                   significance) -> int:
    """Validate the options of :func:`identify`; returns ``max_iter`` with its default."""
    from sdctrl.data._frf import FRF

    if not isinstance(frf, FRF):
        raise TypeError(f"frf must be an sdctrl.FRF, got {type(frf).__name__}")
    if model not in ("complex", "real"):
        raise ValueError(f"model must be 'complex' or 'real', got {model!r}")
    if optimizer not in ("varpro", "gradient", "none"):
        raise ValueError(f"optimizer must be 'varpro', 'gradient' or 'none', got {optimizer!r}")
    if max_iter is None:
        max_iter = 200 if optimizer == "varpro" else 2000
    for name, val in (("max_iter", max_iter),):
        if isinstance(val, bool) or not isinstance(val, int | np.integer) or val < 1:
            raise ValueError(f"{name} must be a positive integer, got {val!r}")
    for name, val in (("tol", tol), ("min_bandwidth", min_bandwidth), ("zeta_max", zeta_max),
                      ("significance", significance)):
        if not (isinstance(val, int | float) and np.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be a positive number, got {val!r}")
    if not np.all(np.isfinite(frf.H)):          # FRF validates, but keep the promise here too
        raise ValueError("frf.H must contain only finite values (no NaN or inf)")
    if frf.H.size and not np.any(frf.H.imag):
        raise ValueError("frf.H is real-valued (magnitudes only?): identification needs the "
                         "complex FRF, magnitude and phase (H = |H| exp(j phase))")
    return max_iter


def _band(frf, band):
    """The FRF lines of the band, the band they span (Hz, the search's) and the band shown
    on the model (``band`` as given, else the lines' span).  One meaning of a band: only its
    lines are used, so ``identify(frf, band=B)`` is ``identify(frf.band(*B))``."""
    from sdctrl._lib.validate import check_band

    if band is None:
        data = frf
    else:
        band = check_band(band, "band")
        data = frf.band(*band)
    fband = (float(data.freq[0]), float(data.freq[-1]))
    return fband, data, fband if band is None else band


def _window_corrected(cm, tau, messages):
    """Poles corrected for an exponential window ``exp(-t/tau)`` of the data: the window
    shifted every pole by ``-1/tau`` (the FRF of ``h(t) exp(-t/tau)`` is ``H(s + 1/tau)``),
    so ``real += 1/tau``; residues are unchanged.  A pole whose decay the window accounts
    for entirely is kept at the damping floor and named."""
    from dataclasses import replace

    if tau is None:
        return cm
    lam = cm.poles + 1.0 / tau
    floor = -ZETA_MIN * np.abs(lam)
    low = ~(lam.real < floor)
    if np.any(low):
        messages.append("exponential window: the decay of the poles at " + ", ".join(
            f"{v:.4g} Hz" for v in np.abs(lam[low]) / (2 * np.pi)) + f" is below the window's "
            f"1/tau = {1 / tau:.4g} rad/s (damping not determined by the data); kept at "
            f"damping {ZETA_MIN:g}: use a longer record or a weaker window")
        lam = np.where(low, floor + 1j * lam.imag, lam)
    return replace(cm, poles=lam, exponential_tau=tau)


def _given_poles(poles, in_band, fband):
    """``(w rad/s, z, side)`` of user-given poles, validated against the band."""
    lam0 = as_array(poles, "poles", ndim=(0, 1), dtype=complex).reshape(-1)
    if lam0.size == 0:
        raise ValueError("poles must contain at least one pole (or be None for automatic "
                         "selection)")
    if np.all(lam0.imag == 0) and np.all(lam0.real > 0):
        raise ValueError("poles must be complex poles in rad/s, -zeta w + j w sqrt(1 - zeta^2) "
                         f"with w = 2 pi f, got real positive values {lam0.real[:4]}: "
                         "frequencies in Hz? (e.g. poles = -0.01 * w + 1j * w, w = 2 * pi * f)")
    if np.any(lam0.imag <= 0):
        raise ValueError("poles must lie in the upper half-plane (Im > 0, rad/s), one per mode")
    if np.any(lam0.real >= 0):
        raise ValueError("poles must be stable (Re < 0, rad/s): initial poles with Re >= 0 "
                         "given (a pole is -zeta w + j w sqrt(1 - zeta^2), w = 2 pi f)")
    w0 = np.abs(lam0)
    z0 = np.clip(-lam0.real / w0, ZETA_MIN * 1.01, ZETA_MAX * 0.99)
    f0 = w0 / (2 * np.pi)
    if in_band is None:
        ib = (f0 >= fband[0]) & (f0 <= fband[1])
    else:
        ib = np.array(in_band, dtype=bool).reshape(-1)
        if ib.size != lam0.size:
            raise ValueError(f"in_band must have one entry per pole ({lam0.size}), "
                             f"got {ib.size}")
    side = np.where(ib, 0, np.where(f0 < fband[0], -1, 1))
    bad = (side == 0) & ((f0 < fband[0]) | (f0 > fband[1]))
    if np.any(bad):
        raise ValueError("in_band: poles marked in band must have their frequency in the "
                         f"band {fband}")
    if np.any((side != 0) & (f0 >= fband[0]) & (f0 <= fband[1])):
        raise ValueError("in_band: poles marked out of band must lie outside the band")
    return w0, z0, side


def _weights(Hm, rules, auto, weighting):
    """Channel weights (automatic selection) and line weights (``weighting="level"``) of the
    search, each None where not applied: both only for data whose noise is independent
    between lines (``rules.smooth_scan``: no exponential window)."""
    if not rules.smooth_scan:
        return None, None
    return (channel_weights(Hm) if auto else None,
            line_weights(Hm) if weighting == "level" else None)


def _searched_data(Hm, cw, lw, rank, seed):
    """The pole search's data: ``Hm`` weighted by channel (``cw``) and by line (``lw``),
    compressed (:func:`compressed_data`), and the relative part the compression leaves out
    (of the unweighted data's norm without line weights, as before them)."""
    Hs = Hm if cw is None else Hm * cw
    Hs = Hs if lw is None else Hs * lw[:, None]
    Y, V, rank = compressed_data(Hs, rank, seed)
    ref = Hm if lw is None else Hs
    n2 = float(np.sum(ref.real**2) + np.sum(ref.imag**2))
    return Y, V, rank, float(max(n2 - float(np.sum(Y**2)), 0) / n2)


def _noise_shape(data, Hm, V, cw=None, lw=None):
    """Point variance (3.59), up to a scale, on the search's (weighted) data columns (None
    without coherence)."""
    if data.coherence is None:
        return None
    pv = np.abs(Hm) ** 2 * (1.0 - data.coherence.reshape(Hm.shape))
    pv = pv if cw is None else pv * cw**2
    pv = pv if lw is None else pv * lw[:, None] ** 2
    return pv if V is None else pv @ V**2


def _select(sel, start, bar, info, messages):
    """Automatic selection; Ctrl-C returns the last complete fit, flagged in ``info``."""
    w0, z0, side, pending = start
    try:
        w, z, side, _ev, sinfo = sel.run(w0, z0, side, bar, pending=pending)
    except KeyboardInterrupt:
        if sel.best is None:
            raise
        w, z, side, _ev, sinfo = sel.best
        info["interrupted"] = True
        messages.append("interrupted: returning the last complete fit")
    info["log"] = sel.log
    _search_info(sinfo, info, messages)
    return w, z, side


def _given_search(prob, w0, z0, side, opts, info, messages):
    """Pole search from the given poles; poles pushed to a bound are reported."""
    fband, optimizer, max_iter, tol = opts
    w, z, sinfo = search_poles(prob, w0, z0, side, fband, optimizer, max_iter, tol)
    if np.any(sinfo.get("at_bound", [])):
        messages.append("poles at a bound of the search (frequency or damping limit): "
                        + ", ".join(f"{x:.4g} Hz" for x in
                                    (w[sinfo['at_bound']] / (2 * np.pi))))
    _search_info(sinfo, info, messages)
    return w, z


def _search_info(sinfo, info, messages):
    info["search"] = {kk: vv for kk, vv in sinfo.items() if kk != "at_bound"}
    if not sinfo.get("converged", True):
        messages.append(f"pole search did not converge: {sinfo.get('message', '')}")
