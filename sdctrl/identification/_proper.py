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

import numpy as np
import scipy.linalg as sla

from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import check_collocated
from sdctrl.identification._complex_modes import scale_residues
from sdctrl.identification._normal_statistics import with_std

__all__ = ["normal_modes", "proper_modes", "scaled_modes", "transformation"]

#: above this spectral radius of ``delta`` the correction is reported as large (warning)
DELTA_WARN = 0.5
#: at or above this spectral radius ``I - delta^2`` of (3.51) is near singular: refused
DELTA_MAX = 0.9
#: poles of magnitude (rad/s) beyond this, or below its inverse, are refused: Omega = |lambda|^2
#: and the products of (3.44) leave double precision (1e150^2 = 1e300)
POLE_RANGE = 1e150


def normal_modes(cm, collocated=None, *, modes=None, tol: float = 1e-13, maxiter: int = 50):
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
       modes (in exact data ``phib[:, a] = cphi[s, :]`` for a collocated pair ``(s, a)``).

    The poles of the result are the identified poles (the transformation is exact for
    proper modes); the maximum relative deviation is reported in ``info``.

    Parameters
    ----------
    cm : ComplexModeModel
        Identified complex modes (displacement residues) with at least as many sensors
        as modes.  Every pole of ``cm`` becomes a normal mode; its ``E`` and ``F``
        asymptotic terms are carried over unchanged.
    collocated : sequence of (int or str, int or str), optional
        Collocated ``(sensor, actuator)`` pairs (indices or labels) used to scale the
        complex modes (3.24); default ``cm.collocated``.  Several pairs are combined in
        the least-squares sense.
    modes : array_like of int or bool, optional
        Modes of ``cm`` to transform (indices, or a boolean mask such as ``cm.in_band``).
        The default -- the one to use -- is every pole, in-band or not: properness
        enforced on the full set fits the data best (leaving the out-of-band poles out
        loses their contribution near the band edges, several percent of the FRF), and
        :func:`sdctrl.hybrid` keeps the out-of-band modes that pair with an FE mode and
        absorbs the others into its residual terms.  Only if the transformation fails
        with them are the out-of-band poles left out, with a warning.
    tol : float
        Relative tolerance of the Newton iteration on the Riccati residual (3.52).
    maxiter : int
        Maximum number of Newton iterations.

    Returns
    -------
    NormalModeModel
        ``Omega`` diagonal in (rad/s)^2, full ``Gamma`` in rad/s, ``cphi`` (ns, n),
        ``phib`` (n, na), ``E`` and ``F`` of ``cm`` (None when negligible: below
        ``1e-10`` of the modal flexibility scale, see ``info["E_relative_size"]`` and
        ``info["F_relative_size"]``), labels of ``cm``.
        ``info`` holds the diagnostics: ``properness_before``/``properness_after``
        (``||psi psi^T|| / ||psi psi^H||``), ``delta`` and ``delta_eigenvalues``,
        ``delta_radius`` (max modulus, must be well below 1, 3.54),
        ``riccati_residual``, ``newton_iterations``, ``mass_eigenvalues``,
        ``damping_eigenvalues``, ``stiffness_eigenvalues`` (of ``M_T, C_T, K_T``),
        ``positive_definite`` (dict mass/damping/stiffness), ``in_band`` (per normal mode,
        the flag of the pole it matches), ``band`` (of ``cm``), ``poles_used`` (indices
        of the poles of ``cm`` transformed), ``poles_left_out`` and ``poles_left_out_hz``
        (the others, which :func:`sdctrl.hybrid` warns about), ``pole_error`` (max relative
        deviation of the poles from ``cm.poles``), ``residue_error`` (relative residue
        misfit of the result), ``collocation_error``, ``c_T`` and ``sensor_eigenvalues``
        (the (3.47) spectrum, kept ones first), ``M_T``, ``C_T``, ``K_T``.

    Raises
    ------
    TypeError
        ``cm`` is not a ComplexModeModel or ``collocated`` is not a sequence of pairs.
    ValueError
        No collocated pair, pairs out of range, fewer sensors than modes (not treated
        by the thesis), a mode unobserved at the collocated pairs, a Riccati iteration
        that does not converge to a small root (``|eig(delta)| < 0.9``; the minimum
        condition 3.54 needs ``< 1``), or an identified mass
        or stiffness (3.45) that is not positive definite.

    Warns
    -----
    RuntimeWarning
        Non-positive-definite damping (3.45), a large correction
        (``|eig(delta)| > 0.5``), poles of the result that depart from the identified
        ones by more than ``1e-6``, or out-of-band poles left out because the
        transformation fails with them.

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
    in_band = np.asarray(cm.in_band, bool)
    if modes is not None:
        return _transform(cm, _mode_selection(modes, cm.n), pairs, tol, maxiter)
    sel = np.arange(cm.n)
    if in_band.all() or in_band.sum() == 0:
        return _transform(cm, sel, pairs, tol, maxiter)
    try:
        return _transform(cm, sel, pairs, tol, maxiter)
    except ValueError as exc:
        out = np.flatnonzero(~in_band)
        warnings.warn(f"normal_modes: with the out-of-band pole(s) {out.tolist()} "
                      f"({np.round(cm.frequency[out], 3).tolist()} Hz) the transformation "
                      f"fails ({exc}); they are left out and their contribution is lost",
                      RuntimeWarning, stacklevel=2)
        return _transform(cm, np.flatnonzero(in_band), pairs, tol, maxiter)


def _transform(cm, sel, pairs, tol, maxiter):
    """Steps 1-5 of :func:`normal_modes` on the poles ``sel`` of ``cm``."""
    from sdctrl.modal._normal_model import NormalModeModel

    ns = cm.ns
    lam, R = np.asarray(cm.poles)[sel], np.asarray(cm.residues)[sel]
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
    with single_thread():                         # small matrices: BLAS threads only hurt
        cpsi, psib = scaled_modes(R, pairs)
        # --- reduced coordinates q_T (3.46)-(3.47) -------------------------------------
        info: dict = {"collocated": pairs}
        if ns == n:
            cT = np.eye(n)
        else:
            X = 2.0 * ((cpsi * lam) @ cpsi.T).real                    # c M^-1 c^T (3.47)
            ev, V = np.linalg.eigh(0.5 * (X + X.T))
            order = np.argsort(-np.abs(ev))
            ev, V = ev[order], V[:, order]
            cT = V[:, :n]
            info["sensor_eigenvalues"] = ev
            if np.any(ev[:n] <= 0):
                warnings.warn("normal_modes: the kept eigenvalues of (c psi) Lambda (c psi)^T "
                              "(3.47) are not all positive; the identified mass will not be "
                              "positive definite", RuntimeWarning, stacklevel=3)
        psi = cT.T @ cpsi                                              # (3.46) LS fit
        # --- properness (3.40) by the optimal correction (3.51)-(3.52) ------------------
        psi_p, rinfo = proper_modes(psi, tol=tol, maxiter=maxiter)
        info.update(rinfo)
        # --- exact transformation (3.44) and PD checks (3.45) ---------------------------
        MT, CT, KT, pinfo = transformation(psi_p, lam)
        info.update(pinfo)
        # --- undamped reduced eigenproblem ------------------------------------------------
        w2, phi = sla.eigh(KT, MT)
        Gamma = phi.T @ CT @ phi
        Gamma = 0.5 * (Gamma + Gamma.T)
        cphi = cT @ phi
        # complex modes of the normal-mode model (mu = I): Psi = phi^-1 psi~ = phi^T M psi~
        Psi = phi.T @ MT @ psi_p
        phib = _phib_from_residues(R, cT @ psi_p, Psi)

    info.update({"c_T": cT, "M_T": MT, "C_T": CT, "K_T": KT,
                 "cpsi": cpsi, "psib": psib, "psi_proper": psi_p})
    E, F = _asymptotic(cm.E, cm.F, lam, R, info)
    nm = NormalModeModel(np.diag(w2), Gamma, cphi, phib, E=E, sensors=cm.sensors,
                         actuators=cm.actuators, F=F)
    # --- checks on the result ------------------------------------------------------------
    pole_err = _pole_error(nm.poles, lam)
    Rn = _residues(cphi, Psi, phib)
    info["pole_error"] = pole_err
    info["residue_error"] = float(np.linalg.norm(Rn - R) / max(np.linalg.norm(R), 1e-300))
    info["collocation_error"] = max(
        float(np.linalg.norm(phib[:, a] - cphi[s]) / max(np.linalg.norm(cphi[s]), 1e-300))
        for s, a in pairs)
    if pole_err > 1e-6:
        warnings.warn(f"normal_modes: poles of the normal-mode model depart from the "
                      f"identified ones by {pole_err:.2e} (relative)", RuntimeWarning,
                      stacklevel=3)
    info["poles_used"] = np.asarray(sel)
    left = np.setdiff1d(np.arange(cm.n), sel)
    info["poles_left_out"] = left
    info["poles_left_out_hz"] = np.asarray(cm.frequency)[left]
    info["in_band"] = _mode_in_band(w2, lam, np.asarray(cm.in_band, bool)[sel])
    info["band"] = None if cm.band is None else tuple(float(v) for v in cm.band)
    nm = nm.replace(info={**info, "source": "normal_modes"})
    return with_std(nm, cm, lambda c: _transform(c, sel, pairs, tol, maxiter))   # (3.4)


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
def scaled_modes(residues: np.ndarray, pairs) -> tuple[np.ndarray, np.ndarray]:
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

    Returns
    -------
    cpsi : ndarray, shape (ns, n)
    psib : ndarray, shape (n, na)
    """
    cpsi, psib, k = scale_residues(residues, pairs)
    for j in range(cpsi.shape[1]):
        if k["sigma1"][j] == 0:
            raise ValueError(f"cm: mode {j} has a zero residue matrix and cannot be scaled")
        if k["observed"][j] < 1e-12 * len(pairs):
            raise ValueError(f"cm: mode {j} is not observed at the collocated pairs "
                             f"{tuple(pairs)}; it cannot be scaled (3.24)")
        if k["z"][j] == 0:
            raise ValueError(f"cm: mode {j} is not controlled at the collocated pairs "
                             f"{tuple(pairs)}; it cannot be scaled (3.24)")
    return cpsi, psib


def proper_modes(psi: np.ndarray, tol: float = 1e-13, maxiter: int = 50):
    """Closest proper complex modes, eq. (3.51), by the small real root of (3.52).

    With ``A0 = psi psi^T`` and ``G = conj(psi) psi^T`` summed over the ``2 n`` modes
    (both real symmetric), the Riccati equation (3.52) reads
    ``A0 - delta G - G delta + delta A0 delta = 0``.  Newton's method from
    ``delta = 0`` solves, at each step, the Sylvester equation
    ``(G - delta A0) X + X (G - A0 delta) = F(delta)`` and converges to the root that
    tends to 0 with the properness error (a generic stable-subspace Riccati solver may
    return a large root, useless here).  The corrected modes are
    ``psi~ = (I - delta^2)^-1 (psi - delta conj(psi))``.

    The thesis proposes the real positive-definite root.  In practice the small root is
    real and symmetric but generally *indefinite* (eigenvalues of both signs, of the order
    of the properness error); it is the anti-stabilising solution of the CARE
    ``G X + X G - X A0 X - A0 = 0`` (Hamiltonian ``[[G, -A0], [A0, -G]]``), while the
    stabilising one returned by standard solvers has ``|eig| >> 1`` and violates the
    minimum condition (3.54), ``|eig(delta)| < 1``.

    Parameters
    ----------
    psi : ndarray, shape (n, n)
        Complex modes (upper-half-plane poles) in the reduced coordinates.
    tol : float
        Relative tolerance on the Riccati residual.
    maxiter : int
        Maximum Newton iterations.

    Returns
    -------
    psi_p : ndarray, shape (n, n)
        Proper complex modes.
    info : dict
        ``delta``, ``delta_eigenvalues``, ``delta_radius``, ``riccati_residual``,
        ``newton_iterations``, ``properness_before``, ``properness_after``.
    """
    n = psi.shape[0]
    A0 = 2.0 * (psi @ psi.T).real
    G = 2.0 * (psi @ psi.conj().T).real
    A0, G = 0.5 * (A0 + A0.T), 0.5 * (G + G.T)
    scale = np.linalg.norm(G)
    before = float(np.linalg.norm(A0) / scale)
    delta = np.zeros((n, n))
    res = np.linalg.norm(A0) / scale
    it = 0
    while res > tol and it < maxiter:
        F = A0 - delta @ G - G @ delta + delta @ A0 @ delta
        X = sla.solve_sylvester(G - delta @ A0, G - A0 @ delta, F)
        delta = delta + 0.5 * (X + X.T)
        it += 1
        F = A0 - delta @ G - G @ delta + delta @ A0 @ delta
        new = np.linalg.norm(F) / scale
        if not np.isfinite(new):
            break
        if it > 5 and new > 0.5 * res and new > 1e3 * tol:
            res = new
            break                                      # stagnation: not converging
        res = new
    ev = np.linalg.eigvals(delta)
    radius = float(np.abs(ev).max()) if n else 0.0
    ev = np.sort(ev.real) if np.allclose(ev.imag, 0) else ev       # delta is symmetric
    if not np.isfinite(res) or res > max(1e3 * tol, 1e-8) or radius >= DELTA_MAX:
        raise ValueError(
            f"cm: the Riccati equation (3.52) has no small real root from delta = 0 "
            f"(residual {res:.2e}, max |eig(delta)| = {radius:.3g} after {it} Newton steps); "
            f"the identified complex modes are too far from proper (properness error "
            f"{before:.2e}) or badly scaled")
    if radius > DELTA_WARN:
        warnings.warn(f"normal_modes: large properness correction, max |eig(delta)| = "
                      f"{radius:.3g} (should be well below 1, 3.54)", RuntimeWarning,
                      stacklevel=3)
    psi_p = np.linalg.solve(np.eye(n) - delta @ delta, psi - delta @ psi.conj())
    after = float(np.linalg.norm(2.0 * (psi_p @ psi_p.T).real)
                  / np.linalg.norm(2.0 * (psi_p @ psi_p.conj().T).real))
    return psi_p, {"delta": delta, "delta_eigenvalues": ev, "delta_radius": radius,
                   "riccati_residual": float(res), "newton_iterations": it,
                   "properness_before": before, "properness_after": after}


def transformation(psi: np.ndarray, lam: np.ndarray):
    """Exact transformation (3.44) of proper complex modes to ``M_T, C_T, K_T``; (3.45).

    ``M_T = (psi Lambda psi^T)^-1``, ``C_T = -M_T (psi Lambda^2 psi^T) M_T`` and
    ``K_T = -(psi Lambda^-1 psi^T)^-1``, sums over the ``2 n`` modes.

    Parameters
    ----------
    psi : ndarray, shape (n, n), complex
        Proper complex modes (one column per upper half-plane pole).
    lam : ndarray, shape (n,), complex
        The poles (rad/s).

    Returns
    -------
    MT, CT, KT : ndarray, shape (n, n)
    info : dict
        ``mass_eigenvalues``, ``damping_eigenvalues``, ``stiffness_eigenvalues`` and
        ``positive_definite`` (dict of bools).

    Raises
    ------
    ValueError
        When the identified mass or stiffness is not positive definite (3.45).
    """
    def ssum(d):
        X = 2.0 * ((psi * d) @ psi.T).real
        return 0.5 * (X + X.T)

    Minv, S2, Kinv = ssum(lam), ssum(lam**2), -ssum(1.0 / lam)
    em, ek = np.linalg.eigvalsh(Minv), np.linalg.eigvalsh(Kinv)
    pd = {"mass": bool(em.min() > 0), "stiffness": bool(ek.min() > 0)}
    if not pd["mass"]:
        raise ValueError(
            f"cm: the identified mass (psi Lambda psi^T)^-1 (3.44) is not positive definite "
            f"(3.45; eigenvalues of its inverse {np.array2string(em, precision=3)}): the "
            f"complex modes are badly identified, badly scaled or coupled to modes outside "
            f"the model")
    if not pd["stiffness"]:
        raise ValueError(
            f"cm: the identified stiffness -(psi Lambda^-1 psi^T)^-1 (3.44) is not positive "
            f"definite (3.45; eigenvalues of its inverse {np.array2string(ek, precision=3)})")
    MT = np.linalg.inv(Minv)
    MT = 0.5 * (MT + MT.T)
    KT = np.linalg.inv(Kinv)
    KT = 0.5 * (KT + KT.T)
    CT = -MT @ S2 @ MT
    CT = 0.5 * (CT + CT.T)
    ec = sla.eigh(CT, MT, eigvals_only=True)       # damping relative to mass: rad/s
    pd["damping"] = bool(ec.min() >= -1e-12 * max(np.abs(ec).max(), 1e-300))
    if not pd["damping"]:
        warnings.warn(_damping_advice(ec), RuntimeWarning, stacklevel=4)
    info = {"mass_eigenvalues": np.linalg.eigvalsh(MT), "stiffness_eigenvalues":
            np.linalg.eigvalsh(KT), "damping_eigenvalues": ec, "positive_definite": pd}
    return MT, CT, KT, info


# --- helpers ---------------------------------------------------------------------------------
def _damping_advice(ec: np.ndarray) -> str:
    """The non-positive damping warning (3.45): what was found and what to do about it."""
    rel = ec.min() / max(np.abs(ec).max(), 1e-300)
    cause = ("small: typically noise on a lightly damped or out-of-band mode; identify with "
             "more lines or less noise around it" if rel > -1e-2 else
             "large: look for a pole that is not a structural mode (cm.in_band, "
             "cm.singular_value_ratios(); leave it out with modes=...) or a wrong collocated "
             "pair (same point, same direction, same sign)")
    return (f"normal_modes: the identified damping matrix is not positive semi-definite "
            f"(3.45; min eigenvalue {ec.min():.3g} rad/s against max {ec.max():.3g}, "
            f"{rel:.1e} of it). The model keeps the identified stable poles and can be used "
            f"as is, but it is not passive along one direction, which matters for passivity "
            f"arguments and bounds on Gamma (5.2.2). This one is {cause}; "
            f"nm.info['damping_eigenvalues'] has the spectrum.")


def _asymptotic(E, F, lam, R, info, rtol: float = 1e-10):
    """``E`` and ``F`` of the complex-mode model, None when negligible (round-off of a fit).

    ``E`` is compared with the off-resonance flexibility scale of the modes,
    ``max_j max|R_j| / |lambda_j|``, and ``F`` through ``F / w^2`` at the lowest pole; a
    negligible ``F`` would otherwise add needless rigid-body states (2.24) to the
    state-space form.
    """
    ref = max(float(np.max(np.abs(R).max(axis=(1, 2)) / np.abs(lam))), 1e-300)
    wmin = float(np.abs(lam).min())
    out = []
    for name, X, scale in (("E", E, 1.0), ("F", F, wmin**-2)):
        size = float(np.abs(X).max()) * scale if X is not None and np.size(X) else 0.0
        keep = size > rtol * ref
        info[f"{name}_relative_size"] = size / ref
        out.append(np.array(X, float) if keep else None)
    return out


def _mode_selection(modes, n: int) -> np.ndarray:
    """Validated integer indices of the selected modes (``modes`` indices or boolean mask)."""
    try:
        m = np.array(modes, copy=True)
    except (TypeError, ValueError) as exc:
        raise TypeError("modes must be an array of mode indices or a boolean mask") from exc
    if m.dtype == bool:
        if m.shape != (n,):
            raise ValueError(f"modes as a boolean mask must have {n} entries, got {m.shape}")
        idx = np.flatnonzero(m)
    elif m.ndim == 1 and (m.size == 0 or np.issubdtype(m.dtype, np.integer)):
        idx = m.astype(int)
        if np.any(idx < 0) or np.any(idx >= n):
            raise ValueError(f"modes: index out of range [0, {n})")
        if np.unique(idx).size != idx.size:
            raise ValueError("modes: repeated index")
    else:
        raise TypeError("modes must be a 1-D array of mode indices or a boolean mask")
    if idx.size == 0:
        raise ValueError("modes selects no mode")
    return idx


def _phib_from_residues(R: np.ndarray, cpsi_p: np.ndarray, Psi: np.ndarray) -> np.ndarray:
    """Real ``phib`` minimising ``sum_j ||R_j - cpsi_j Psi_j^T phib||^2`` (linear LS)."""
    n, ns, na = R.shape
    D = np.einsum("ij,kj->jik", cpsi_p, Psi).reshape(n * ns, Psi.shape[0])
    rhs = R.reshape(n * ns, na)
    A = np.vstack([D.real, D.imag])
    b = np.vstack([rhs.real, rhs.imag])
    return np.linalg.lstsq(A, b, rcond=None)[0]


def _residues(cphi: np.ndarray, Psi: np.ndarray, phib: np.ndarray) -> np.ndarray:
    """Residues ``cphi Psi_j Psi_j^T phib`` of a normal-mode model, shape (n, ns, na)."""
    return np.einsum("ij,jk->jik", cphi @ Psi, Psi.T @ phib)


def _pole_error(p_model: np.ndarray, p_id: np.ndarray) -> float:
    """Max relative distance of each identified pole to the model's matching pole."""
    from scipy.optimize import linear_sum_assignment

    p_model = p_model[p_model.imag > 0]
    if p_model.size != p_id.size:
        return float("inf")
    cost = np.abs(p_id[:, None] - p_model[None, :]) / np.abs(p_id)[:, None]
    r, c = linear_sum_assignment(cost)
    return float(cost[r, c].max()) if r.size else 0.0
