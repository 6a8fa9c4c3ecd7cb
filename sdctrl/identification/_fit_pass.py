"""One identification pass of :func:`~sdctrl.identify` with a given line weighting.

:func:`fit_pass` is the body of the identification (thesis 3.2.1): the data scaled
(exactly, by a power of two), weighted by channel and by line (``weighting="level"``,
:mod:`~sdctrl.identification._line_weights`) and compressed; the initial poles (peaks
merged with the stable LSCF poles) and the automatic selection (under the rules of
independent lines, a start whose residual decays over the record ends the pass:
:class:`~sdctrl.identification._residual_decay.CorrelatedLines`, and
:func:`~sdctrl.identify` starts again under the rules of windowed data), or the search
from given poles; the final residues on the full data
(:mod:`~sdctrl.identification._final_fit`), the fit assessed against the data and the poles
corrected for an exponential window.  It
returns the model and the messages it would warn with; :func:`~sdctrl.identify` warns the
messages of the pass it keeps (``weighting="auto"`` runs two passes and keeps the one
closer to the data).

Internal module: the functions trust their inputs (validated by :func:`~sdctrl.identify`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.validate import QUANTITY_POWER
from sdctrl.data._coherence import measured_coherence
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
from sdctrl.identification._quality import assessed
from sdctrl.identification._residual_decay import (
    DECAY_LIMIT,
    CorrelatedLines,
    decay_message,
    residual_decay,
)
from sdctrl.identification._residues import n_per_pole
from sdctrl.identification._search import ZETA_MIN, PoleProblem, search_poles
from sdctrl.identification._selection import AutoSelection

__all__ = ["PassOptions", "fit_pass"]


@dataclass(frozen=True, eq=False)
class PassOptions:
    """The options of :func:`~sdctrl.identify` a pass runs with (validated there).

    ``given`` is ``(w rad/s, zeta, side)`` of user-given poles, None for the automatic
    selection; the other fields are :func:`~sdctrl.identify`'s arguments of the same name.
    """

    given: tuple | None
    model: str
    optimizer: str
    asymptotic: bool
    compress_rank: int | None
    max_iter: int
    tol: float
    min_bandwidth: float
    zeta_max: float
    significance: float
    seed: int | None


def fit_pass(data, bands, opts: PassOptions, rules, weighting: str, bar):
    """One identification of ``data`` (the band's lines) with line weighting ``weighting``
    (``"none"`` or ``"level"``); ``bands`` is ``(fband, shown)``: the band of the search
    and the band shown on the model.  Returns ``(cm, messages)``."""
    fband, shown = bands
    nf = data.freq.size
    asym = (True, True) if opts.asymptotic else (False, False)
    npp = n_per_pole(opts.model)
    auto = opts.given is None
    e = _exponent(data.H)
    Hm = scaled(data.H.reshape(nf, -1), e)
    if auto:
        w0, z0, side = peak_set(data, data.freq, Hm.reshape(data.H.shape), fband, e)
    else:
        w0, z0, side = opts.given
    _check_lines(nf, (npp + 2) * w0.size + sum(asym), w0.size)
    p_guess = npp * (w0.size + 6) + sum(asym)
    rank = max(p_guess + 16, 40) if opts.compress_rank is None else int(opts.compress_rank)
    cw, lw = _weights(Hm, rules, auto, weighting)
    Y, V, rank, residual = _searched_data(Hm, cw, lw, rank, opts.seed)
    info = {"optimizer": opts.optimizer, "model": opts.model, "asymptotic": opts.asymptotic,
            "compress_rank": int(rank), "lines": int(nf), "channels": int(Hm.shape[1])}
    if V is not None:
        info["compression_residual"] = residual
    if auto:
        merged = _algebraic(data.freq, Y if lw is None else Y / np.tile(lw, 2)[:, None],
                            fband, (w0, z0, side), opts.zeta_max, info)
        if 2 * nf >= (npp + 2) * merged[0].size + sum(asym):   # else: the peaks only
            w0, z0, side, pending = merged
        else:
            pending = np.zeros(w0.size, bool)
    messages = [] if rules.residual_decay is None else [
        decay_message(rules.residual_decay, data.freq)]
    info["residual_decay"] = rules.residual_decay
    prob = PoleProblem(Y, 2j * np.pi * data.freq, QUANTITY_POWER[data.quantity],
                       opts.model, asym, bar, lw)
    if auto:
        _lines_independent(prob, (w0, z0, side, pending), data.freq, rules)
        sel = AutoSelection(prob, data.freq, fband, opts.optimizer, opts.max_iter, opts.tol,
                            opts.min_bandwidth, opts.zeta_max, opts.significance,
                            messages.append, _noise_shape(data, Hm, V, cw, lw), rules=rules,
                            collocated=CollocatedResidues.of(data, Hm, prob))
        w, z, side = _select(sel, (w0, z0, side, pending), bar, info, messages)
        if not np.any(side == 0):
            raise ValueError(f"frf: no mode found in the band {fband[0]:g}-{fband[1]:g} Hz "
                             "(no significant resonance in the data; give poles= to fit "
                             "chosen poles anyway)")
    else:
        w, z = _given_search(prob, w0, z0, side,
                             (fband, opts.optimizer, opts.max_iter, opts.tol), info, messages)
    info["nfev"] = prob.nfev
    cm = final_model(data, shown, Hm, (w, z, side), FitSpec(opts.model, asym, lw), info,
                     messages, e)
    cm, quality = assessed(cm, data)          # against the data as measured (windowed)
    cm = _window_corrected(cm, data.exponential_tau, messages)
    return cm, messages + quality


def _lines_independent(prob, start, freq, rules):
    """Under the rules of independent lines, raise :class:`CorrelatedLines` when the
    residual of the start (its poles but the pending peaks, residues by least squares)
    decays over the record (:mod:`~sdctrl.identification._residual_decay`): the noise is
    correlated between lines and the identification starts again under the rules of
    windowed data.  The residual is taken as fitted: divided by line weights, the residual
    of a level-weighted start is the error at the quiet lines, which decays (the family's
    plate and ladder at 1%, independent lines: 2.5 and 2.3; as fitted -1.1 and -0.7)."""
    if not rules.smooth_scan:
        return
    w0, z0, _side, pending = start
    if not np.any(~pending):
        return
    ev = prob.evaluate(np.log(np.concatenate([w0[~pending], z0[~pending]])))
    decay = residual_decay(ev["r"], freq)
    if decay is not None and decay > DECAY_LIMIT:
        raise CorrelatedLines(decay)


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
    the LSCF poles of every order go to ``info["stabilisation"]`` (then the model's field).
    ``Y`` is the search's data without the line weights (the caller divides them out): the
    LSCF fits a rational function of ``s``, which the data are (combinations of channels:
    a sum of modes) and the weighted data are not (noise-free six-mode receptance, level-
    weighted: one stable pole of six, the rest found by the residual scan)."""
    w0, z0, side = peaks
    w_l, z_l, stab = lscf_candidates(freq, Y, fband, int(np.count_nonzero(side == 0)),
                                     zeta_max)
    info["stabilisation"] = stab
    df = float(np.median(np.diff(freq))) if freq.size > 1 else 1.0
    return initial_candidates(w_l, z_l, w0, z0, side, df)


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
    coh = measured_coherence(data)
    if coh is None:
        return None
    pv = np.abs(Hm) ** 2 * (1.0 - coh.reshape(Hm.shape))
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
