"""Hybrid experimental/analytical models: construction (thesis 5.1.1, eq. 5.1).

A test identifies, for the modes of its band, the modal frequencies ``Omega``, the
damping matrix ``Gamma`` and the modal observabilities ``(c phi)_ID`` at the sensors.  An
FE model gives shapes on all its DOFs, but less accurate frequencies and shapes.  The
hybrid model (5.1)

``I p'' + Gamma_c p' + Omega_c p = phi_c^T b_c u``, ``y = c_c phi_c p``

keeps the measured ``Omega``/``Gamma`` of the measured modes, uses the measured modes
*expanded* onto all FE DOFs (4.7), and appends analytic FE modes below and above the test
band and static correction modes.  Because its shapes live on FE DOFs, the hybrid predicts
untested sensors/actuators, modifications ``dM, dC, dK`` given on FE DOFs (5.2) and D-strut
loops (5.3)-(5.4): the :class:`~sdctrl.hybrids._predictions.HybridModel` class and its predictions
(with the static correction of modifications) are in :mod:`sdctrl.hybrids._predictions`, the
expansion and pairing in :mod:`sdctrl.hybrids._expansion`, the shapes and residual terms
in :mod:`sdctrl.hybrids._hybrid_basis`; this module builds the model (5.1.1).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from sdctrl._lib.threads import single_thread
from sdctrl.fe._static import consistent_static_modes
from sdctrl.fe._fe_checks import shapes_on_dofs
from sdctrl.fe._fe_model import check_fe_model
from sdctrl.hybrids._hybrid_basis import (
    ModeSet,
    band_lines,
    build_basis,
    fe_modes_upto,
    select_residual,
    stack_parts,
)
from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.hybrids._hybrid_records import (
    HybridConstruction,
    ModePairing,
    ResidualChoice,
    pairing_report,
)
from sdctrl.hybrids._predictions import HybridModel
from sdctrl.hybrids._expansion import MAC_POOR, pair_modes
from sdctrl.hybrids._measured_residual import measured_appended_poles, out_of_band_candidates
from sdctrl.hybrids._out_of_band import trial_out_of_band
from sdctrl.hybrids._tested_io import TestedIO, keep_tested, realise_residual
from sdctrl.updating._costs import logls
from sdctrl.hybrids._auto import (SAME_PREDICTIONS, choose_residual, has_tested,
                                  held_out_scores, reference_lines)
from sdctrl.hybrids._io_checks import measured_w2, placed_io, placed_loads, warn_left_out
from sdctrl.hybrids._mass_scale import fe_mass_scale, measured_scale_std
from sdctrl.hybrids._pairing_rules import absorbed, mean_damping, warn_poor

__all__ = ["hybrid", "pairing_report"]

_EXPANSIONS = ("regularised", "paired")
_RESIDUALS = ("identified", "fe", "tested")


# ----------------------------------------------------------------------------------------
# the hybrid model
# ----------------------------------------------------------------------------------------
def hybrid(fe, nm, sensor_c, actuator_b=None, *, fmax: float | None = None,
           static_b=None, mac_min: float = MAC_POOR, expansion: str = "regularised",
           residual: str = "auto") -> HybridModel:
    """Hybrid experimental/analytical normal-mode model, eq. (5.1).

    Built from an identified normal-mode model ``nm`` (as returned by
    :func:`sdctrl.normal_modes` with its default: the band's poles as normal modes, the
    others as identified residual dynamics ``nm.residual``, which ``residual="identified"``
    does not carry: its appended FE modes and residual terms, fitted to ``nm``'s whole
    response at the tested I/O, stand for them; ``residual="tested"`` keeps them there) and
    an FE model ``fe``:

    - measured modes: the identified ``Omega`` (frequencies) and ``Gamma`` (full damping
      matrix, non-proportional terms kept), shapes expanded onto all FE DOFs (4.7).  By
      default (``expansion="regularised"``) the expansion basis holds every FE mode down
      to a quarter of the lowest paired eigenvalue and up to ``fmax`` plus the static
      shapes of the test inputs, and the fit is regularised toward the paired FE mode
      (:func:`~sdctrl.hybrids._expansion.expand_regularised`), its prior spread and noise
      level chosen per mode by leave-one-sensor-out cross-validation, so that the shapes
      predict the DOFs without a sensor (untested outputs, modifications) rather than
      interpolate the identification errors.  At the tested sensors the model keeps the
      identified observabilities ``(c phi)_ID`` and at the tested inputs the identified
      ``nm.phib`` (offsets of ``c phi_Ex`` carried like ``E`` below: dropped by
      :meth:`~sdctrl.hybrids._predictions.HybridModel.with_io`).
      ``expansion="paired"`` is the thesis's ``A = (c phi_FE)^+ (c phi)_ID`` on the
      paired FE modes.  The expanded shapes' scale: the test's (collocated residues, 3.24)
      combined with the FE modal mass ``phi_Ex^T M phi_Ex`` by their variances (``nm.std``
      against the FE's spread learnt from the modes), so a mode the tested inputs barely
      excite takes the FE's scale and a well-measured one keeps the test's
      (:mod:`sdctrl.hybrids._mass_scale`, ``construction.mass_scale``; nothing is rescaled
      when ``nm`` has no statistics);
    - out-of-band identified poles (``nm.properness.in_band`` False) that pair with an FE
      mode (MAC >= ``mac_min``) are kept as measured modes; the others (poles that absorb
      what lies beyond the band) are absorbed into the residual terms below
      (``construction.absorbed``);
    - every other FE mode up to ``fmax`` (5.1.1): the low ones (suspension, rigid-body) as
      FE shapes, the others made mass-orthogonal to the expanded shapes; damping ratio the
      mean measured one, no damping coupling;
    - static correction modes (2.21) of the test inputs, made consistent with those
      shapes (:func:`sdctrl.fe._static.consistent_static_modes`), critically damped (2.20);
    - residual representation chosen from the test (``residual="auto"``, the default): each
      of ``"identified"``,
      ``"tested"`` (when ``nm`` has residual terms) and ``"fe"`` below is built and scored
      by leave-one-actuator-out prediction on the test's own channels (the model built
      without actuator ``j`` predicts its column through ``with_io`` on the FE DOFs,
      logLS against ``nm``'s column over the band; leave-one-sensor-out when the test has
      one actuator; at most 6 folds); the lowest mean score wins, candidates within 2% of
      it or not beaten on every fold tie and the one closest to ``nm`` at the tested I/O
      is kept; with one
      sensor and one actuator, that closest one (:mod:`sdctrl.hybrids._auto`).  The
      choice and its scores are ``construction.residual`` (``representation``,
      ``chosen_by``, ``held_out``, ``loo_scores``, ``nominal_scores``).  The folds reuse
      the FE modes, the static response ``K^-1 b`` of the test inputs (4.23: one solve for
      every static correction of the call) and, holding out an actuator, the expansion
      prior.  On the family of
      test structures it keeps ``"tested"`` (the cluster at 1% noise with every shaker:
      ``"fe"``), whose nominal model is the identified one at the tested I/O, where
      ``"identified"`` is 1.2x (truss) to 45x (plate) further from it; its StateSpace then
      carries the residual dynamics and ``F``'s correction modes (more states, see
      :meth:`~sdctrl.modal.NormalModeModel.to_statespace`);
    - residual terms (``residual="identified"``): the test's residual flexibility
      ``E`` is kept -- less what the appended modes give at the test I/O, a constant fitted
      over the band -- and the modal masses of the low modes are corrected to the
      identified residual mass ``F`` (a correction carried, like ``E``, by the low modes'
      observabilities at the tested sensors only: their FE shapes are kept); the appended FE
      frequencies are scaled by ``kappa``, the median measured/FE frequency ratio of the paired
      modes, but an appended mode the test measured as residual dynamics (an in-band mode not made
      normal, paired by its residue's shape) takes the measured frequency and damping ratio (the
      other appended modes take the measured modes' mean ratio, 5.1.1)
      (:mod:`sdctrl.hybrids._measured_residual`); with ``residual="auto"`` so may one the
      test holds as an out-of-band pole, when both the fit at the tested I/O and the
      held-out prediction are better with it (a mode just above the band that the FE put
      inside it, not a pole standing for several modes: :mod:`sdctrl.hybrids._out_of_band`,
      trials on ``construction.out_of_band``).  Each of these steps is
      kept only if it brings the model closer to ``nm`` at the tested I/O
      (:func:`sdctrl.hybrids._hybrid_basis.select_residual`; ``construction.residual``).  The kept
      ``E`` is carried by the static correction modes' observabilities (2.22), so that
      the realisation is exact (``construction.residual_flexibility``).
      ``residual="fe"``: the thesis's hybrid, FE frequencies and no residual term;
      ``residual="tested"``: at the tested I/O the model keeps what the test measured
      (:mod:`sdctrl.hybrids._tested_io`): the measured modes, ``nm.residual`` (the
      out-of-band poles as complex-mode terms, 3.7), ``nm.E`` (a correction term far above
      the band) and ``nm.F``, with every other mode unobserved at the tested sensors (an
      offset of ``-c phi``, dropped by ``with_io`` like ``E``); it reproduces ``nm`` there
      (family of test structures: within 1% of its logLS, against 1.4-10x above it for
      ``"identified"``), while the FE modes keep their shapes for the predictions.  Its
      StateSpace carries the residual block (more states) and realises the improper
      residual terms through the correction filter (2.19)-(2.20);
    - optionally static correction modes for ``static_b``.

    The model carries its FE model and test I/O (``fe``, ``sensor_c``, ``actuator_b``),
    so that :meth:`~sdctrl.hybrids._predictions.HybridModel.with_feedback`,
    :meth:`~sdctrl.hybrids._predictions.HybridModel.with_io` and
    :meth:`~sdctrl.hybrids._predictions.HybridModel.with_modification` add the static
    correction of each modification by default (the key to large stiffness changes, thesis
    Table 5.2).
    The outputs are ``y = c_c phi_c p`` with ``c_c = sensor_c`` (5.1).

    Parameters
    ----------
    fe : FEModel
        The analytical model (need not be accurate: its shapes span the expansion).
    nm : NormalModeModel
        Identified normal modes (diagonal ``Omega``, rad/s^2; ``Gamma`` rad/s; ``cphi`` at
        the test sensors; ``E`` and ``F`` residual terms; ``properness.band`` and
        ``properness.in_band`` as :func:`sdctrl.normal_modes` sets them).
    sensor_c : array_like, shape (ns, N), or sequence of ns DOF labels
        The test sensors placed on the FE DOFs (rows match ``nm.sensors``).
    actuator_b : array_like, shape (N, na), or sequence of na DOF labels, optional
        FE input shapes of the model's inputs (``phib = phi_c^T actuator_b`` for the
        modes other than the measured ones, which keep the identified ``nm.phib``); by
        default point forces at ``nm.actuators`` when they are FE DOF labels.
    fmax : float, optional
        Highest frequency (Hz) of the FE modes used; default five times the highest
        measured frequency.
    static_b : array_like, shape (N, k), optional
        Input shapes (e.g. a strut, :meth:`FEModel.strut`) for which static correction
        modes, consistent with the hybrid's shapes, are appended (``kind`` ``"static"``).
    mac_min : float
        Pairs with a MAC below this value are reported with a warning (in-band modes) or
        absorbed (out-of-band poles).
    expansion : {"regularised", "paired"}
        Expansion basis and fit, see above.
    residual : {"auto", "identified", "fe", "tested"}
        Chosen by leave-one-out prediction on the test's channels (default), or: residual
        terms from the test (selected against ``nm``), the thesis's FE modes, or the
        test's own residual dynamics, ``E`` and ``F`` kept at the tested I/O (needs an
        ``nm`` that has some: as :func:`sdctrl.normal_modes` builds it).

    Returns
    -------
    HybridModel
        Modes sorted by frequency; ``shapes`` (also ``expanded``) on ``fe.dofs``;
        ``E`` None unless part of the kept residual flexibility could not be carried by
        the correction modes;
        ``kind`` per mode (``"measured"``, ``"fe"``, ``"residual"`` for the static
        correction of the test inputs, ``"static"`` for ``static_b``; ``measured`` its
        mask), ``n_static`` and ``construction``
        (:class:`~sdctrl.hybrids._hybrid_records.HybridConstruction`: the pairing with its
        poor pairs, the FE x test MAC, the absorbed ``nm`` modes, the expansion ``A``, the
        mean damping, the residual representation, variant and their scores, the kept
        residual flexibility).

    Raises
    ------
    TypeError
        ``fe`` is not an FEModel or ``nm`` not a NormalModeModel.
    ValueError
        Inconsistent shapes, unknown DOF labels, non-diagonal ``nm.Omega``, a
        non-positive ``fmax``, an FE model with fewer modes than ``nm``, unknown
        ``expansion`` or ``residual``.

    Warns
    -----
    UserWarning
        Poor FE/test pairing of an in-band mode (MAC below ``mac_min``), fewer sensors than
        measured modes, inputs that cannot be placed on the FE model, or an ``nm`` built
        from a subset of the identified poles (``normal_modes(cm, modes=...)``: use the
        default).

    Examples
    --------
    >>> import sdctrl as sd
    >>> from sdctrl.testbeds._truss import SENSORS, SHAKERS
    >>> fe = sd.testbed()
    >>> nm = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 18)
    >>> h = sd.hybrid(fe, nm, list(SENSORS))
    >>> bool(h.construction.pairing.mac.min() > 0.999)
    True
    """
    check_fe_model(fe, "fe")
    if not isinstance(nm, NormalModeModel):
        raise TypeError(f"nm must be a NormalModeModel, got {type(nm).__name__}")
    for name, val, allowed in (("expansion", expansion, _EXPANSIONS),
                               ("residual", residual, _RESIDUALS + ("auto",))):
        if val not in allowed:
            raise ValueError(f"{name} must be one of {allowed}, got {val!r}")
    if residual == "tested" and not has_tested(nm):
        raise ValueError("residual='tested' needs an nm with residual terms (E, F or "
                         "residual dynamics, as sd.normal_modes builds it); this nm has none: "
                         "use residual='identified'")
    c, b = placed_io(fe, nm, sensor_c, actuator_b)
    # one BLAS thread for the whole build (the policy of identify, sdctrl._lib.threads):
    # its kernels are small dense products and solves, which BLAS threads on the shared
    # 2-core machine made 2-10x slower, in CPU time too (issue 27)
    with single_thread():
        w2_id, fmax, mac_min = measured_w2(nm, fmax, mac_min)
        f_id = np.sqrt(w2_id) / (2 * np.pi)
        f_fe, phi_fe = fe_modes_upto(fe, max(fmax, 1.05 * float(f_id.max())), nm.n)
        setup = _Setup(fe, f_fe, phi_fe, mac_min, expansion)
        warn_left_out(nm)
        loads, unexcited = placed_loads(fe, nm, b)
        if unexcited:
            warnings.warn("hybrid: nm.actuators are not FE DOF labels, so the appended FE "
                          "modes are not excited by the model's inputs; give actuator_b",
                          stacklevel=2)
        # K^-1 of the test inputs (4.23), solved once: the static corrections of the model, of
        # its expansion basis and of every fold of "auto" are made from its columns
        response = None if loads is None else fe.static_response(loads)
        if residual != "auto":
            return _variants(setup, nm, c, loads, (residual,), static_b=static_b,
                             response=response)[0][residual]
        return _auto(setup, nm, c, loads, static_b, response)


def _auto(setup, nm, c, loads, static_b, response):
    """``residual="auto"``: every candidate built from the whole test, the out-of-band poles
    that give appended FE modes their frequency tried (:mod:`sdctrl.hybrids._out_of_band`),
    the kept candidate chosen by :func:`~sdctrl.hybrids._auto.choose_residual`.
    ``response`` is ``K^-1 loads`` shared by all the builds (None: each build solves for its
    own loads, the same to round-off)."""
    candidates = _RESIDUALS if has_tested(nm) else ("identified", "fe")
    full, prior, offered = _variants(setup, nm, c, loads, candidates, static_b=static_b,
                                     response=response)

    def builder(poles):
        def build(nm_k, c_k, loads_k, names, response_k):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return _variants(setup, nm_k, c_k, loads_k, names, out_of_band=poles,
                                 prior=prior if c_k is c else None, response=response_k)[0]
        return build

    names = tuple(dict.fromkeys(SAME_PREDICTIONS.get(k, k) for k in full))
    scores = held_out_scores(builder(()), nm, c, loads, names, response=response)
    kept, trials, held = (), (), {}
    if offered:
        hz, Href = reference_lines(nm)
        base = (logls(full["identified"].frf(hz).H, Href),
                None if scores is None else scores[2]["identified"])
        kept, trials, held = trial_out_of_band(
            offered, lambda poles: _variants(setup, nm, c, loads, ("identified",),
                                             static_b=static_b, prior=prior, response=response,
                                             out_of_band=poles)[0]["identified"],
            builder, nm, c, loads, base, response=response)
    if kept:
        full = _variants(setup, nm, c, loads, candidates, static_b=static_b, prior=prior,
                         response=response, out_of_band=kept)[0]
        if scores is not None:       # "fe" does not use the measured frequencies
            per = held[kept[0]] if len(kept) == 1 else held_out_scores(
                builder(kept), nm, c, loads, ("identified",), response=response)[2]["identified"]
            scores = (scores[0], scores[1], {**scores[2], "identified": per})
    chosen, record = choose_residual(builder(kept), nm, c, loads, full, response=response,
                                     scores=scores)
    model = full[chosen]
    built = model.construction
    return model.replace(construction=replace(
        built, residual=replace(built.residual, **record), out_of_band=trials))


@dataclass(frozen=True, eq=False)
class _Setup:
    """What every build of one call of :func:`hybrid` shares (the folds of
    ``residual="auto"`` included): the FE model, its modes up to ``fmax`` (Hz, shapes), the
    pairing threshold and the expansion."""

    fe: object
    f_fe: np.ndarray
    phi_fe: np.ndarray
    mac_min: float
    expansion: str


def _variants(setup: _Setup, nm, c, loads, residuals, *, static_b=None, prior=None,
              response=None, out_of_band=()):
    """The hybrid models of ``nm`` tested at ``c``/``loads``, one per residual
    representation of ``residuals``, sharing their pairing and expansion (5.1.1, 4.7):
    ``(dict of name to HybridModel, the expansion prior, the out-of-band poles offered)``;
    ``prior`` and ``response`` (``K^-1 loads``) reused when given
    (:func:`~sdctrl.hybrids._hybrid_basis.build_basis`); ``out_of_band``: indices of
    ``nm.residual``'s out-of-band poles that give their paired appended FE mode its
    frequency (:mod:`sdctrl.hybrids._out_of_band`)."""
    fe, f_fe, phi_fe = setup.fe, setup.f_fe, setup.phi_fe
    w2_id = np.clip(np.diag(nm.Omega), 0, None)
    f_id = np.sqrt(w2_id) / (2 * np.pi)
    fe_idx, mac_pairs, macs = pair_modes(c @ phi_fe, nm.cphi, f_fe, f_id)
    kept = ~absorbed(nm, mac_pairs, setup.mac_min)
    km = np.flatnonzero(kept)
    if c.shape[0] < km.size:
        warnings.warn(f"hybrid: {c.shape[0]} sensors for {km.size} measured modes; the "
                      "expansion (4.7) needs more sensors than modes to be determined",
                      stacklevel=3)
    poor = warn_poor(km, mac_pairs, setup.mac_min, fe_idx, f_id, f_fe)
    base = build_basis(fe, w2_id[kept], nm.cphi[:, kept], c, loads, f_fe, phi_fe,
                       fe_idx[kept], setup.expansion, prior, response)
    # the FE modal mass's scale where the test's collocated residues cannot scale a mode
    ratio = np.log(f_id[kept] / f_fe[fe_idx[kept]])
    scale = fe_mass_scale(fe.M, base.expanded, measured_scale_std(nm, kept), km,
                          ratio - np.median(ratio))
    if scale is not None:
        base.expanded, base.A = base.expanded * scale.factor, base.A * scale.factor
    # appended FE modes the test measured as residual dynamics take the measured pole
    base.appended_test_w2, base.appended_test_zeta = measured_appended_poles(
        nm, c, phi_fe, f_fe, base.appended_w2, setup.mac_min, out_of_band)
    offered = out_of_band_candidates(nm, c, phi_fe, f_fe, base.appended_w2, setup.mac_min)
    zeta_mean = mean_damping(nm, np.sqrt(w2_id), kept)
    pairing = ModePairing(test_mode=km, fe_mode=fe_idx[kept], mac=mac_pairs[kept],
                          test_hz=f_id[kept], fe_hz=f_fe[fe_idx[kept]], poor=poor)
    built = HybridConstruction(pairing=pairing, mac=macs, absorbed=np.flatnonzero(~kept),
                               expansion=base.A, mean_damping=zeta_mean,
                               fe_frequency_hz=f_fe, mass_scale=scale)
    w_band = band_lines(nm, np.sqrt(w2_id[kept]))
    common = _Common(fe, nm, kept, base, c, loads, zeta_mean, built, w_band, static_b)
    fits = {}                     # "tested" appends its FE modes as "identified" does
    for res in residuals:
        key = "fe" if res == "fe" else "identified"
        if key not in fits:
            fits[key] = select_residual(nm, kept, base, c, nm.phib[kept], loads, zeta_mean,
                                        key)
    return ({res: _one(common, res, fits["fe" if res == "fe" else "identified"])
             for res in residuals}, base.prior, offered)


@dataclass(frozen=True, eq=False)
class _Common:
    """The parts of :func:`_variants` its residual representations share."""

    fe: object
    nm: NormalModeModel
    kept: np.ndarray
    base: object
    c: np.ndarray
    loads: np.ndarray | None
    zeta: float
    built: HybridConstruction
    w_band: np.ndarray
    static_b: object


def _one(cm: _Common, residual: str, fit) -> HybridModel:
    """The hybrid model of one residual representation (``"identified"``, ``"fe"``,
    ``"tested"``) from its residual fit ``(parts, report)`` (:func:`select_residual`)."""
    nm, c, loads = cm.nm, cm.c, cm.loads
    parts, report = fit
    modes = stack_parts(parts, loads, c.shape[0])
    if cm.static_b is not None:
        modes = _append_static(cm.fe, cm.static_b, modes, loads)
    modes = modes.sorted()
    kinds = modes.kind
    built = replace(cm.built, residual=ResidualChoice(**report, representation=residual),
                    residual_flexibility=parts["E"],
                    mass_correction=parts.get("mass_correction"))
    tested = TestedIO(modes.w2, modes.Gamma, c @ modes.shapes + modes.offset, modes.phib,
                      kinds)
    if residual == "tested":
        cphi, res, built = _keep_tested(nm, built, tested, cm.w_band)
        E, F = None, nm.F
    else:
        cphi, E = realise_residual(tested.cphi, modes.w2, modes.phib, kinds, parts["E"])
        F = res = None
    return HybridModel(np.diag(modes.w2), modes.Gamma, cphi, modes.phib, E=E, F=F,
                       residual=res, sensors=nm.sensors, actuators=nm.actuators,
                       shapes=modes.shapes, dofs=cm.fe.dofs, fe=cm.fe,
                       sensor_c=c, actuator_b=loads, kind=kinds,
                       n_static=int(np.sum(kinds == "static")), construction=built)


def _keep_tested(nm, built, tested, w_band):
    """``residual="tested"``: observabilities, residual dynamics and the construction record
    (:func:`sdctrl.hybrids._tested_io.keep_tested`)."""
    cphi, carried, res = keep_tested(nm, built.absorbed, tested, w_band)
    variant = f"tested I/O kept; appended modes as in {built.residual.variant}"
    return cphi, res, replace(built, residual_flexibility=carried, mass_correction=None,
                              residual=replace(built.residual, variant=variant))


def _append_static(fe, static_b, modes: ModeSet, loads) -> ModeSet:
    """Static correction modes for ``static_b`` consistent with the shapes of ``modes``.

    They are diagonalised on the stiffness together with the static correction of the test
    inputs (one Ritz block, so that the static response to ``static_b`` is exact for an
    exact FE model); the modes that hold most of the ``static_b`` directions are labelled
    ``"static"``.
    """
    Bs, _ = shapes_on_dofs(static_b, fe.N, fe.dofs, "static_b")
    res = modes.kind == "residual"
    V2, _ = consistent_static_modes(fe, Bs, modes.shapes)
    k2 = V2.shape[1]
    if not k2:
        return modes
    J = np.hstack([modes.shapes[:, res], V2])                  # mass-orthonormal block
    Kj = J.T @ np.asarray(fe.K @ J)
    wc2, U = np.linalg.eigh(0.5 * (Kj + Kj.T))
    V = J @ U
    share = np.sum(U[res.sum():] ** 2, axis=0)                 # weight of static_b parts
    label = np.full(V.shape[1], "residual")
    label[np.argsort(-share, kind="stable")[:k2]] = "static"
    keep = ~res
    n = keep.sum()
    G = np.zeros((n + V.shape[1],) * 2)
    G[:n, :n] = modes.Gamma[np.ix_(keep, keep)]
    G[n:, n:] = np.diag(2 * np.sqrt(np.clip(wc2, 0, None)))
    pb = np.vstack([modes.phib[keep], V.T @ loads if loads is not None
                    else np.zeros((V.shape[1], modes.phib.shape[1]))])
    off = np.hstack([modes.offset[:, keep], np.zeros((modes.offset.shape[0], V.shape[1]))])
    return ModeSet(np.hstack([modes.shapes[:, keep], V]), np.concatenate([modes.w2[keep], wc2]),
                   G, pb, np.concatenate([modes.kind[keep], label]), off)
