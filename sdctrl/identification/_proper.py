"""Normal modes from complex modes (thesis section 3.3).

The identified complex modes, scaled by the collocated residues (3.24)-(3.25), are
replaced by the closest *proper* complex modes (properness 3.40, optimal correction
3.51 with the small real root of the Riccati equation 3.52); proper modes give the
truncated mass, damping and stiffness matrices exactly (3.44), whose undamped
eigenproblem yields ``Omega``, the full ``Gamma``, ``cphi`` and ``phib``.  With more
sensors than modes the reduced coordinates ``c_T`` of (3.46)-(3.47) are used.

Notation (thesis): ``psi`` are the complex modes in the reduced coordinates ``q_T``,
``lambda`` the poles; ``[psi, conj(psi)]`` and ``[lambda, conj(lambda)]`` are the full
sets of ``2 n`` modes over which the sums of (3.40)-(3.45) run, so that every sum is
``2 Re(...)`` of the sum over the upper-half-plane modes.
"""

from __future__ import annotations


import warnings
from dataclasses import replace

import numpy as np
import scipy.linalg as sla

from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import check_bool, check_collocated
from sdctrl.identification._collocated_passivity import passive_at_pairs
from sdctrl.identification._collocated_scaling import proper_phase, unscaled_poles
from sdctrl.identification._complex_modes import scale_residues
from sdctrl.identification._properness import proper_modes
from sdctrl.identification._properness_record import Properness
from sdctrl.identification._reduced_matrices import transformation
from sdctrl.identification._reciprocity import needs_transpose, via_transpose
from sdctrl.identification._normal_statistics import with_std
from sdctrl.identification._part_selection import closer_parts
from sdctrl.identification._mode_split import (OUT_OF_BAND, improper_terms, mode_selection,
                                               residual_block, split_modes)
from sdctrl.identification._proper_terms import (asymptotic_terms, fitted_to_frf, model_residues,
                                                  phib_from_residues, pole_error)

__all__ = ["Properness", "normal_modes", "scaled_modes"]

#: poles of magnitude (rad/s) beyond this, or below its inverse, are refused: Omega = |lambda|^2
#: and the products of (3.44) leave double precision (1e150^2 = 1e300)
POLE_RANGE = 1e150


def normal_modes(cm, collocated=None, *, modes=None, tol: float = 1e-13, maxiter: int = 50,
                 std: bool = True, passive: bool = False):
    """Normal-mode model with non-proportional damping from a complex-mode model (3.3).

    Steps (thesis section 3.3):

    1. scaled complex modal observability ``cpsi`` and controllability ``psib`` from the
       dyadic part of each residue and the collocated pairs (3.24)-(3.25);
    2. reduced coordinates ``q_T``: the sensors themselves when ``ns == n``, else the
       ``n`` dominant eigenvectors ``c_T`` of ``2 Re(cpsi Lambda cpsi^T) = c M^-1 c^T``
       (3.47) and ``psi_T = c_T^T cpsi``, the least-squares solution of (3.46);
    3. properness ``psi psi^T = 0`` (3.40) enforced by the smallest correction (3.51),
       ``psi~ = (I - delta^2)^-1 (psi - delta conj(psi))`` with the *small* real root
       ``delta`` of the Riccati equation (3.52), found by Newton's method from
       ``delta = 0`` on its Sylvester linearisation;
    4. the exact transformation (3.44) ``M_T = (psi Lambda psi^T)^-1``,
       ``C_T = -M_T psi Lambda^2 psi^T M_T``, ``K_T = -(psi Lambda^-1 psi^T)^-1``, checked
       for positive definiteness (3.45), and the undamped reduced eigenproblem
       ``K_T phi = M_T phi Omega`` (mass-normalised): ``Omega``, ``Gamma = phi^T C_T phi``,
       ``cphi = c_T phi``;
    5. ``phib`` by linear least squares on the identified residues given the proper
       modes (in exact data ``phib[:, a] = cphi[s, :]`` for a collocated pair ``(s, a)``);
    6. the rows of ``phib`` of close modes (whose FRF contributions overlap, their residues
       traded between them by noise and by the correction) refitted to the identified FRF
       relative to its level, the logLS cost (3.12) linearised
       (:func:`~sdctrl.identification._proper_terms.fitted_to_frf`): a small transfer where
       their large contributions nearly cancel keeps its anti-resonances.

    A mode whose collocated residues are all within 3 standard deviations (3.58) -- a
    localised mode far from every shaker -- is not scaled by the test: its scaling's phase in
    step 1 is then that of a proper mode (3.40) and its least-squares magnitude is kept, with
    a warning (:mod:`~sdctrl.identification._collocated_scaling`); its mass scale is not
    measured.

    The poles of the result are the identified poles (the transformation is exact for
    proper modes); the maximum relative deviation is ``nm.properness.pole_error``.

    Never all or nothing: the in-band poles become normal modes, the out-of-band poles
    (``cm.in_band`` False: fitted to absorb modes outside the band, one may stand for
    several) and the poles whose properness cannot be enforced (no small real root of
    (3.52), unscalable at the collocated pairs (3.24), more modes than sensors (3.46)) are
    kept as they are, complex-mode terms (3.7) in ``nm.residual``
    (:class:`~sdctrl.modal.ResidualDynamics`, realised in the 2x2-block form 3.26-3.33).
    When the in-band set cannot be made proper as a whole, the fewest poles are kept that
    way, and of the removals of that many, the one whose kept modes need the smallest
    correction (3.54) (:mod:`~sdctrl.identification._mode_split`).
    Where properness enforced on the in-band modes alone changes their residues significantly
    (more than 3 standard deviations of the residue, 3.58) and the identified model holds
    poles kept as residual dynamics the in-band modes may couple to (out-of-band poles or an
    in-band pole whose properness failed: section 3.3's assumption fails, e.g. a dashpot),
    the identified residue minus the normal mode's (3.7 against 2.15) is kept at
    the same pole in ``nm.residual`` too (reason ``"improper part: ..."``, after the other
    poles; the normal modes are unchanged), for close modes together: all of a group's when
    one, or their sum, is significant (:mod:`~sdctrl.identification._close_modes`).  Where
    the normal modes would still miss the identified model (mean logLS 3.12 on its lines) by
    more than the identified model misses its data (``cm.search.logls``), the parts
    significant entry by entry that remove the most of it are kept too, the fewest that
    reach it (:mod:`~sdctrl.identification._part_selection`: a norm test is the loud
    channels').  So the normal-mode model reproduces the identified model at the tested I/O.  Which
    poles became modes: ``nm.properness.poles_used``; which stayed residual and why:
    ``nm.residual.source`` and ``nm.residual.reasons`` (:mod:`._mode_split`).  The residual
    dynamics have no shapes: :meth:`~sdctrl.NormalModeModel.modified`,
    :meth:`~sdctrl.NormalModeModel.with_feedback` and ``with_io`` act on the normal modes
    and keep them at the tested I/O; :func:`sdctrl.hybrid` builds on the normal modes only
    (its FE modes stand for the out-of-band dynamics).

    Parameters
    ----------
    cm : ComplexModeModel
        Identified complex modes (displacement residues).  Its ``E`` and ``F``
        asymptotic terms are carried over unchanged.
    collocated : sequence of (int or str, int or str), optional
        Collocated ``(sensor, actuator)`` pairs (indices or labels) used to scale the
        complex modes (3.24); default ``cm.collocated``.  Several pairs are combined in
        the least-squares sense.
    modes : array_like of int or bool, optional
        Poles of ``cm`` to make normal modes (indices, or a boolean mask); the others
        are left out (``properness.poles_left_out``, their contribution lost), except
        those whose properness cannot be enforced, kept as residual dynamics.  Default:
        the in-band poles become modes (every pole when none or all are in band), the
        out-of-band poles residual dynamics -- nothing is lost.
    tol : float
        Relative tolerance of the Newton iteration on the Riccati residual (3.52).
    maxiter : int
        Maximum number of Newton iterations.
    std : bool
        Propagate the identification's statistics to ``nm.std`` (3.4, finite differences
        of the transformation: seconds on a 20-mode test).  False skips it (``nm.std`` is
        None).  ``nm.std`` covers the normal modes only.
    passive : bool
        Step 8: make the model passive at the collocated pairs -- the collocated velocity
        admittance positive real, so that a collocated rate loop closed on
        ``nm.to_statespace()`` is stable as on the structure -- by refitting the
        collocated blocks of the residual dynamics, ``E`` and ``F`` to their in-band
        response under that constraint (a semidefinite program; seconds on six pairs);
        the refit is kept only while the model stays as close to ``cm`` as step 7 asks
        (:mod:`~sdctrl.identification._collocated_passivity`).  The out-of-band poles are
        free outside the band and often are not passive there: on the family's
        ``truss_high`` at 1% noise every collocated rate loop was predicted unstable.
        False (default): the check alone.  Either way ``nm.properness.passivity`` records
        how passive the model is.

    Returns
    -------
    NormalModeModel
        ``Omega`` diagonal in (rad/s)^2, full ``Gamma`` in rad/s, ``cphi`` (ns, n),
        ``phib`` (n, na), ``E`` and ``F`` of ``cm`` (None when negligible: below
        ``1e-10`` of the modal flexibility scale, see ``properness.E_relative_size``),
        labels of ``cm``, and ``properness``: the :class:`Properness` record of the
        construction (properness before/after, ``delta``, ``M_T``/``C_T``/``K_T`` and
        their definiteness, pole and residue errors, the poles used), and ``residual``:
        the poles kept as complex modes with their reasons (None when every pole is a mode).

    Raises
    ------
    TypeError
        ``cm`` is not a ComplexModeModel or ``collocated`` is not a sequence of pairs.
    ValueError
        No collocated pair, pairs out of range, or no pole at all that can be made a
        normal mode.  With fewer sensors than modes and more actuators than sensors the
        transposed test is used, with a warning (reciprocity, a roving-hammer survey).

    Warns
    -----
    RuntimeWarning
        Non-positive-definite damping (3.45), a large correction
        (``|eig(delta)| > 0.5``), poles of the result that depart from the identified
        ones by more than ``1e-6``, or poles kept as residual dynamics because properness
        cannot be enforced on them (named, with the reason).

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> lam = np.array([-0.5 + 60j, -0.8 + 90j])
    >>> phi = np.array([[1.0, 0.5], [0.4, -1.0]])             # c phi, collocated c = b^T
    >>> mu = 2j * lam.imag                                       # psi = phi/sqrt(mu)
    >>> R = np.einsum("ij,kj->jik", phi, phi) / mu[:, None, None]
    >>> cm = sd.ComplexModeModel(lam, R, collocated=[(0, 0), (1, 1)])
    >>> nm = sd.normal_modes(cm)
    >>> bool(np.allclose(nm.poles, lam))
    True
    """
    from sdctrl.identification._complex_modes import ComplexModeModel

    if not isinstance(cm, ComplexModeModel):
        raise TypeError(f"cm must be a ComplexModeModel, got {type(cm).__name__}")
    ns, na = cm.ns, cm.na
    pairs = check_collocated(cm.collocated if collocated is None else collocated, ns, na,
                             "collocated", cm.sensors, cm.actuators)
    if not pairs:
        raise ValueError("collocated must hold at least one (sensor, actuator) pair: the "
                         "complex modes are scaled by collocated residues (3.24)")
    if isinstance(tol, bool) or not np.isfinite(tol) or tol <= 0:
        raise ValueError(f"tol must be a positive number, got {tol!r}")
    if isinstance(maxiter, bool) or not isinstance(maxiter, int | np.integer) or maxiter < 1:
        raise ValueError(f"maxiter must be a positive integer, got {maxiter!r}")
    check_bool(std, "std")
    check_bool(passive, "passive")
    in_band = np.asarray(cm.in_band, bool)
    reasons = {}
    if modes is not None:
        cand = mode_selection(modes, cm.n)
    elif in_band.all() or not in_band.any():
        cand = np.arange(cm.n)
    else:
        cand = np.flatnonzero(in_band)
        reasons = {int(j): OUT_OF_BAND for j in np.flatnonzero(~in_band)}
    if needs_transpose(cm, cand.size):
        return _transposed(cm, pairs, modes=modes, tol=tol, maxiter=maxiter, std=std,
                           passive=passive)
    free = unscaled_poles(cm, pairs, cand)          # scaling phase from properness (3.40)
    sel, failed = split_modes(cand, cm.ns, lambda idx: _transform(
        cm, idx, pairs, tol, maxiter, False, free=free))
    if sel.size == 0:
        raise ValueError("cm: no pole can be made a normal mode (" + "; ".join(
            f"{j}: {why}" for j, why in sorted({**reasons, **failed}.items())) + ")")
    if failed:
        warnings.warn("normal_modes: pole(s) " + "; ".join(
            f"{j} ({cm.frequency[j]:.4g} Hz): {why}" for j, why in sorted(failed.items()))
            + " -- kept as complex-mode residual dynamics (nm.residual)", RuntimeWarning,
            stacklevel=2)
    reasons.update(failed)
    nm = _transform(cm, sel, pairs, tol, maxiter, bool(std), residual=list(reasons), free=free)
    steps = lambda c: _transform(c, sel, pairs, tol, maxiter, False, free=free)  # noqa: E731
    nm, extra = fitted_to_frf(cm, nm, sel, improper_terms(cm, nm, sel, reasons),   # step 6
                              steps)
    extra = closer_parts(cm, nm, sel, reasons, extra)
    return passive_at_pairs(nm.replace(residual=residual_block(cm, reasons, extra)), pairs,
                            cm, passive)                                          # step 8


def _transposed(cm, pairs, **options):
    """:func:`normal_modes` on the transposed test (reciprocity), residual dynamics and
    statistics turned back with the model."""
    keep = []

    def inner(cm_t, pairs_t, **opts):
        nm_t = normal_modes(cm_t, pairs_t, **opts)
        keep.append(nm_t)
        return nm_t.replace(residual=None, std=None)

    nm = via_transpose(inner, cm, pairs, **options)
    res, sd = keep[0].residual, keep[0].std
    if sd is not None:
        sd = {"Omega": sd["Omega"], "Gamma": sd["Gamma"].T, "cphi": sd["phib"].T,
              "phib": sd["cphi"].T}
    return nm.replace(residual=None if res is None else res.transposed(), std=sd)


def _transform(cm, sel, pairs, tol, maxiter, std=True, residual=(), free=()):
    """Steps 1-5 of :func:`normal_modes` on the poles ``sel`` of ``cm`` (``residual``: the
    poles kept as residual dynamics, not left out; ``free``: poles whose scaling's phase
    comes from properness, :func:`._collocated_scaling.proper_phase`), scale-free.

    Every step is homogeneous in the residues: they are divided by ``s = 4^m``, a power of
    two near their size (exact in floating point), and the result scaled back (``cphi``,
    ``phib`` by ``2^m``, ``E``, ``F`` by ``s``), so that products such as
    ``psi psi^T psi psi^T`` neither underflow nor overflow for FRFs of any unit.
    """
    peak = float(np.abs(np.asarray(cm.residues)[sel]).max()) if len(sel) else 0.0
    m = int(np.frexp(peak)[1]) // 2 if np.isfinite(peak) and peak > 0 else 0
    if m == 0:
        nm = _transform_scaled(cm, sel, pairs, tol, maxiter, residual, free)
    else:
        s = 4.0**m
        nm = _scaled_back(_transform_scaled(cm.replace(
            residues=np.asarray(cm.residues) / s, E=None if cm.E is None else cm.E / s,
            F=None if cm.F is None else cm.F / s, statistics=None), sel, pairs, tol, maxiter,
            residual, free), s, 2.0**m)
    if not std:
        return nm
    again = lambda c: _transform(c, sel, pairs, tol, maxiter, False, free=free)  # noqa: E731
    return with_std(nm, cm, again)


def _scaled_back(nm, s: float, r: float):
    """The model of residues ``s R`` from that of ``R`` (``r = sqrt(s)``, powers of two)."""
    p = nm.properness
    ev = None if p.sensor_eigenvalues is None else p.sensor_eigenvalues * s
    rec = replace(p, cpsi=p.cpsi * r, psib=p.psib * r, psi_proper=p.psi_proper * r,
                              sensor_eigenvalues=ev, M_T=p.M_T / s, C_T=p.C_T / s,
                              K_T=p.K_T / s, mass_eigenvalues=p.mass_eigenvalues / s,
                              stiffness_eigenvalues=p.stiffness_eigenvalues / s)
    return nm.replace(cphi=nm.cphi * r, phib=nm.phib * r, E=None if nm.E is None else nm.E * s,
                      F=None if nm.F is None else nm.F * s, properness=rec)


def _transform_scaled(cm, sel, pairs, tol, maxiter, residual=(), free=()):
    """Steps 1-5 of :func:`normal_modes` on residues of order one (see :func:`_transform`)."""
    from sdctrl.modal._normal_model import NormalModeModel

    lam, R = np.asarray(cm.poles)[sel], np.asarray(cm.residues)[sel]
    _check_poles(lam, cm.ns)
    with single_thread():                         # small matrices: BLAS threads only hurt
        cpsi, psib = scaled_modes(R, pairs, sel, unscaled=np.isin(sel, free))
        cT, sensor_ev = _reduced_coordinates(cpsi, lam)
        psi = cT.T @ cpsi                                              # (3.46) LS fit
        # --- properness (3.40) by the optimal correction (3.51)-(3.52) ------------------
        psi_p, corr = proper_modes(psi, tol=tol, maxiter=maxiter)
        # --- exact transformation (3.44) and PD checks (3.45) ---------------------------
        mats = transformation(psi_p, lam)
        # --- undamped reduced eigenproblem ------------------------------------------------
        w2, phi = sla.eigh(mats.K_T, mats.M_T)
        Gamma = phi.T @ mats.C_T @ phi
        Gamma = 0.5 * (Gamma + Gamma.T)
        cphi = cT @ phi
        # complex modes of the normal-mode model (mu = I): Psi = phi^-1 psi~ = phi^T M psi~
        Psi = phi.T @ mats.M_T @ psi_p
        phib = phib_from_residues(R, cT @ psi_p, Psi)
    (E, F), sizes = asymptotic_terms(cm.E, cm.F, lam, R)
    nm = NormalModeModel(np.diag(w2), Gamma, cphi, phib, E=E, sensors=cm.sensors,
                         actuators=cm.actuators, F=F)
    # --- checks on the result ------------------------------------------------------------
    pole_err = pole_error(nm.poles, lam)
    if pole_err > 1e-6:
        warnings.warn(f"normal_modes: poles of the normal-mode model depart from the "
                      f"identified ones by {pole_err:.2e} (relative)", RuntimeWarning,
                      stacklevel=4)
    left = np.setdiff1d(np.arange(cm.n), np.union1d(sel, np.asarray(residual, int)))
    Rn = model_residues(cphi, Psi, phib)
    record = Properness(
        collocated=tuple(pairs), cpsi=cpsi, psib=psib, c_T=cT, sensor_eigenvalues=sensor_ev,
        psi_proper=psi_p, **vars(corr), **vars(mats), pole_error=pole_err,
        residue_error=float(np.linalg.norm(Rn - R) / max(np.linalg.norm(R), 1e-300)),
        collocation_error=max(
            float(np.linalg.norm(phib[:, a] - cphi[s]) / max(np.linalg.norm(cphi[s]), 1e-300))
            for s, a in pairs), **sizes,
        in_band=_mode_in_band(w2, lam, np.asarray(cm.in_band, bool)[sel]),
        band=None if cm.band is None else tuple(float(v) for v in cm.band),
        poles_used=np.asarray(sel), poles_left_out=left,
        poles_left_out_hz=np.asarray(cm.frequency)[left])
    return nm.replace(properness=record)


def _check_poles(lam, ns: int) -> None:
    """Poles within double-precision reach of (3.44) and at most ``ns`` of them (3.46)."""
    n = lam.size
    if n and not (np.abs(lam).max() <= POLE_RANGE and np.abs(lam).min() >= 1 / POLE_RANGE):
        raise ValueError(f"cm: poles of magnitude {np.abs(lam).min():.3g} to "
                         f"{np.abs(lam).max():.3g} rad/s; normal modes need |lambda| in "
                         f"[{1 / POLE_RANGE:g}, {POLE_RANGE:g}] (Omega = |lambda|^2 and the "
                         "transformation (3.44) in double precision): change the time unit")
    if ns < n:
        raise ValueError(f"cm has fewer sensors ({ns}) than modes ({n}): the reduced "
                         "coordinates of (3.46)-(3.47) need ns >= n (the case with fewer "
                         "sensors than modes is not treated, thesis 3.3.3)")


def _reduced_coordinates(cpsi, lam):
    """Reduced coordinates ``c_T`` (3.46)-(3.47) and the (3.47) spectrum (None if ns == n)."""
    ns, n = cpsi.shape
    if ns == n:
        return np.eye(n), None
    X = 2.0 * ((cpsi * lam) @ cpsi.T).real                    # c M^-1 c^T (3.47)
    ev, V = np.linalg.eigh(0.5 * (X + X.T))
    order = np.argsort(-np.abs(ev))
    ev, V = ev[order], V[:, order]
    if np.any(ev[:n] <= 0):
        warnings.warn("normal_modes: the kept eigenvalues of (c psi) Lambda (c psi)^T "
                      "(3.47) are not all positive; the identified mass will not be "
                      "positive definite", RuntimeWarning, stacklevel=5)
    return V[:, :n], ev


def _mode_in_band(w2, lam, in_band) -> np.ndarray:
    """In-band flag of each normal mode: that of the identified pole it matches (by
    frequency, one to one)."""
    from scipy.optimize import linear_sum_assignment

    w = np.sqrt(np.clip(w2, 0, None))
    cost = np.abs(w[:, None] - np.abs(lam)[None, :])
    r, c = linear_sum_assignment(cost)
    out = np.ones(w.size, bool)
    out[r] = in_band[c]
    return out


# --- steps ---------------------------------------------------------------------------------
def scaled_modes(residues: np.ndarray, pairs, index=None, unscaled=None):
    """Scaled complex modal observability and controllability, eq. (3.24)-(3.25).

    The dyadic part of each residue ``R_j ~ u_j w_j^T`` (first singular pair, 3.23) is
    scaled by ``kappa_j`` so that ``cpsi_j = kappa_j u_j`` and ``psib_j = w_j / kappa_j``
    agree at the collocated pairs (``c_s psi_j = psi_j^T b_a``); with several pairs
    ``kappa_j^2`` is their least-squares compromise
    ``sum conj(u_s) w_a / sum |u_s|^2``.  Internal: inputs are trusted.

    Parameters
    ----------
    residues : ndarray, shape (n, ns, na), complex
        Residues of the complex-mode model.
    pairs : sequence of (int, int)
        Collocated (sensor, actuator) index pairs.
    index : sequence of int, optional
        Index of each mode in the complex-mode model, for the error messages.
    unscaled : ndarray of bool, shape (n,), optional
        Modes whose collocated residues are noise: their scaling takes the phase of a proper
        mode (:func:`~sdctrl.identification._collocated_scaling.proper_phase`).

    Returns
    -------
    cpsi : ndarray, shape (ns, n)
    psib : ndarray, shape (n, na)
    """
    cpsi, psib, k = scale_residues(residues, pairs)
    if unscaled is not None and np.any(unscaled):
        cpsi, psib = proper_phase(cpsi, psib, k["z"], unscaled)
    index = range(cpsi.shape[1]) if index is None else index
    for i, j in enumerate(index):
        if k["sigma1"][i] == 0:
            raise ValueError(f"cm: mode {j} has a zero residue matrix and cannot be scaled")
        if k["observed"][i] < 1e-12 * len(pairs):
            raise ValueError(f"cm: mode {j} is not observed at the collocated pairs "
                             f"{tuple(pairs)}; it cannot be scaled (3.24)")
        if k["z"][i] == 0:
            raise ValueError(f"cm: mode {j} is not controlled at the collocated pairs "
                             f"{tuple(pairs)}; it cannot be scaled (3.24)")
    return cpsi, psib

