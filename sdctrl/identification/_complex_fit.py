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
from sdctrl._lib.validate import as_array
from sdctrl.identification._fit_pass import PassOptions, fit_pass
from sdctrl.identification._line_weights import WEIGHTINGS, kept_pass, passes_to_run
from sdctrl.identification._residual_decay import CorrelatedLines
from sdctrl.identification._rules import correlated_rules, selection_rules
from sdctrl.identification._search import ZETA_MAX, ZETA_MIN

__all__ = ["IdentificationWarning", "identify"]


#: default weighting of the lines (:func:`identify`): both fits, the one closer to the data
#: kept (:mod:`~sdctrl.identification._line_weights`)
WEIGHTING = "auto"


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
    weighting : {"auto", "none", "level"}
        Weight of each line in the fit: ``"none"`` (every line alike: the lines at
        resonances dominate), ``"level"``, the inverse of its level across the channels
        (the least squares become the logLS cost 3.12 linearised, the maximum-likelihood
        fit of noise relative to the response; :mod:`~sdctrl.identification._line_weights`),
        or ``"auto"`` (default): both fits, the one whose mean logLS against the data is
        the lower kept (with a coherence, the one whose misfit over the point variance
        3.59 is the lower: ``cm.search.weighting_variance``); each wins on some tests: the
        weighted one fits the tails of modes outside the band, near-null channels and
        displacement data, the unweighted one where the loud lines of the resonances
        carry the information.  Data without
        measurable noise (noise-free) get the unweighted fit only.  Weighting applies
        to data whose noise is independent between lines (not through an exponential
        window: there, one unweighted fit; nor to data that do not record a window but
        whose starting residual decays over the record as windowed noise does,
        ``cm.search.residual_decay``, :mod:`~sdctrl.identification._residual_decay`:
        they are fitted under the rules of windowed data, the damping not corrected).
        What was applied: ``cm.search.weighting``;
        with ``"auto"``, both fits' logLS: ``cm.search.weighting_logls``.  Warnings are
        those of the fit kept.
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
        where it lies and what to try; in-band poles forming multiplets of a drifting mode;
        data without a recorded window whose noise is correlated between lines (the rules
        of windowed data applied, how to give the window so that the damping is corrected).

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
    if weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    fband, data, shown = _band(frf, band)
    given = None if poles is None else _given_poles(poles, in_band, fband)
    opts = PassOptions(given, model, optimizer, bool(asymptotic), compress_rank, max_iter, tol,
                       min_bandwidth, zeta_max, significance, seed)
    with single_thread():                     # one BLAS policy for the whole call
        bar = progress_bar(desc="identify", unit="eval", enabled=progress)
        try:
            passes = _passes(data, (fband, shown), opts, weighting, bar)
        finally:
            bar.close()
    cm, caught = kept_pass(passes, data)
    for w in caught:
        warnings.warn(w.message, w.category, stacklevel=2)
    return cm


def _passes(data, bands, opts, weighting, bar):
    """The passes of :func:`identify`, ``[(cm, warnings), ...]``, under the rules the data
    call for (:func:`~sdctrl.identification._rules.selection_rules`); again under the rules
    of windowed data when the start of a pass shows lines correlated by a window the FRF
    does not record (:class:`~sdctrl.identification._residual_decay.CorrelatedLines`)."""
    def under(rules):
        todo = passes_to_run(weighting, rules, data.H.reshape(data.freq.size, -1))
        return [_recorded(data, bands, opts, rules, w, bar) for w in todo]

    try:
        return under(selection_rules(data))
    except CorrelatedLines as seen:       # outside the handler below: no chained traceback
        decay = seen.decay
    return under(correlated_rules(decay))


def _recorded(data, bands, opts, rules, weighting, bar):
    """One pass (:func:`~sdctrl.identification._fit_pass.fit_pass`) with the warnings it
    gives recorded (warned by :func:`identify` for the pass it keeps): ``(cm, warnings)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cm, messages = fit_pass(data, bands, opts, rules, weighting, bar)
        for msg in messages:
            warnings.warn(msg, IdentificationWarning, stacklevel=2)
    return cm, list(caught)


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
