"""Normal-mode models passive at their collocated pairs (step 8 of ``normal_modes``).

A structure is passive: the velocity admittance of its collocated pairs,
``Y(jw) = jw H_cc(jw)``, has a positive semi-definite Hermitian part at every frequency (the
energy argument behind the positive-definite damping of (3.45), and what makes collocated
rate feedback -- a D-strut, 5.3 -- unconditionally stable).  The identified model need not
be: the out-of-band poles kept as residual dynamics stand for several modes beyond the band
(3.7; one pole for six modes on the family's ``truss_high``) and their residues, fitted to the
in-band tail only, are free to be non-passive near their own resonance outside the band;
improper parts and the asymptotic terms ``E``, ``F`` likewise.  A collocated rate loop
closed on such a model is predicted unstable where the structure is stable: measured on
``main`` at one collocated pair, a loop gain of one at mid-band, roll-off at 500 Hz, on
``truss_high`` at 1% noise every pair went unstable (at 15-18 Hz, the three poles standing
for the six modes below the band), and the plate, the cluster (noise-free) and the ladder (a
negative ``E``, unstable at 10 kHz) had such pairs too.

The data do not fix what those terms do outside the band, so the collocated blocks of the
terms the model carries as they are -- every residual-dynamics residue, ``E`` and ``F`` --
are refitted to their own in-band response (the logLS metric 3.12 linearised: each entry
relative to the model's level, on a uniform grid of the band and around each pole) under
the constraint that the whole collocated admittance (the normal modes held fixed) is
positive real:

* each term ``R/(s - l) + conj``, ``R = A - jB`` (real symmetric blocks, reciprocity),
  adds ``Re(jw c1) A + Re(jw c2) B`` to the Hermitian part (``c1 = (2s + 2 sigma)/D``,
  ``c2 = 2 w_d / D``, ``D = s^2 + 2 sigma s + |l|^2``), linear in ``A``, ``B``;
* ``E`` and ``F`` add nothing to the Hermitian part on the axis but are the admittance's
  residues at infinity and zero: ``E_cc``, ``F_cc`` positive semi-definite;
* positive semi-definiteness is imposed at a set of frequencies grown by cutting planes
  (the worst points of a fine log grid two decades beyond each band edge, until none is
  below ``-TOL`` of the admittance's peak), a semidefinite program (cvxpy).

Measured at 1% noise (seeds 1-3): ``truss_high`` from every pair unstable to every pair
stable, the model's mean logLS against the data 0.00089 / 0.00106 / 0.00162 -> 0.00093 /
0.00107 / 0.00164; the ladder, plate and cluster passive with changes below 2e-5 (tests in
``tests/test_collocated_passivity.py``).  Models already passive are returned unchanged.  Where what
keeps the model from passive is needed to fit the band (the normal modes' own damping or scaling,
3.45, or a non-reciprocal ``F``) the refit would move the model away from the identified one and
is not kept: the worst dip is reported (``nm.properness.passivity``; the family's truss).

Internal module: the functions trust their inputs (validated by ``normal_modes``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sps

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.records import freeze_arrays
from sdctrl.identification._quality import mean_logls

__all__ = ["CollocatedPassivity", "passive_at_pairs"]

#: log-grid points per decade of the passivity check
PER_DECADE = 80
#: decades beyond each band edge the check covers
DECADES = 2
#: a dip of the Hermitian part below this fraction of the admittance's peak is round-off
TOL = 1e-7
#: cutting-plane rounds, and frequencies added per round
ROUNDS = 8
ADDED = 48
#: uniform lines of the band in the refit (and points around each pole)
FIT_LINES = 400
POLE_OFFSETS = (-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0)
#: and on its flanks at these multiples of its damping ratio (relative frequency)
WINGS = tuple(3.0 * 10.0 ** (0.5 * k) for k in range(12))
#: a change of the model below this mean logLS (3.12; about 1% rms in magnitude, below the
#: floor of any of the family's tests at 1% noise) is always allowed (noise-free fits)
FLOOR = 1e-4


@dataclass(frozen=True, eq=False)
class CollocatedPassivity(FrozenState):
    """How passive the normal-mode model is at its collocated pairs (module notes).

    Read as ``nm.properness.passivity``.

    Attributes
    ----------
    pairs : tuple of (int, int)
        The collocated (sensor, actuator) pairs checked.
    worst_before, worst_after : float
        Smallest eigenvalue of the Hermitian part of the collocated velocity admittance over
        the check's grid, relative to the admittance's largest norm there (>= 0: passive),
        before and after the refit.
    worst_frequency : float
        Where ``worst_before`` was found (Hz).
    refitted : bool
        Whether the collocated blocks of the residual dynamics, ``E`` and ``F`` were
        refitted (False: passive already, or nothing to refit, or the refit failed).
    fit_change : float
        Mean logLS (3.12) of the refitted collocated blocks' response against the original
        one on the band (0 when no refit was tried; set for a refit not kept too).
    frequencies : ndarray
        Frequencies (Hz) where positive semi-definiteness was imposed.
    status : str
        ``"passive"``, ``"not passive"`` (checked only: ``normal_modes(...,
        passive=False)``), ``"refitted"``, ``"nothing to refit"``, why the refit was not
        kept, or the solver's failure.
    """

    pairs: tuple = ()
    worst_before: float = 0.0
    worst_after: float = 0.0
    worst_frequency: float = float("nan")
    refitted: bool = False
    fit_change: float = 0.0
    frequencies: np.ndarray | None = None
    status: str = "passive"

    def __post_init__(self):
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class _Terms:
    """The adjustable terms: poles of the residual dynamics and which of E, F are present."""

    poles: np.ndarray
    has_E: bool
    has_F: bool


def _sym_map(k: int) -> np.ndarray:
    """``vec(X) = P u`` for a symmetric ``k x k`` ``X`` and its upper triangle ``u``."""
    iu = np.triu_indices(k)
    P = np.zeros((k * k, iu[0].size))
    for c, (i, j) in enumerate(zip(*iu)):
        P[i * k + j, c] = P[j * k + i, c] = 1.0
    return P


def _coefficients(lam, w):
    """``c1``, ``c2`` of the module notes (displacement), shape (nf, m)."""
    s = 1j * w[:, None]
    sig, wd = -lam.real[None, :], lam.imag[None, :]
    D = s**2 + 2 * sig * s + np.abs(lam[None, :]) ** 2
    return (2 * s + 2 * sig) / D, 2 * wd / D


def _blocks(terms: _Terms, w, vel: bool):
    """Per-frequency coefficient of each variable block (nf, nblocks): A_j, B_j, E, F."""
    c1, c2 = _coefficients(terms.poles, w)
    s = 1j * w[:, None]
    cols = [c1 * s, c2 * s] if vel else [c1, c2]
    out = np.empty((w.size, 2 * terms.poles.size), complex)
    out[:, 0::2], out[:, 1::2] = cols
    extra = []
    if terms.has_E:
        extra.append(s[:, 0] if vel else np.ones(w.size))
    if terms.has_F:
        extra.append(1.0 / s[:, 0] if vel else 1.0 / s[:, 0] ** 2)
    return np.column_stack([out, *extra]) if extra else out


def _collocated(X, pairs):
    si, ai = [i for i, _ in pairs], [a for _, a in pairs]
    return X[..., si, :][..., ai]


def _worst(Y):
    """Smallest eigenvalue of the Hermitian part of each ``Y[f]`` relative to max norm."""
    Hh = 0.5 * (Y + np.conj(np.swapaxes(Y, -1, -2)))
    ev = np.linalg.eigvalsh(Hh)[:, 0]
    peak = max(float(np.abs(Y).max()), 1e-300)
    return ev / peak


def _grid(nm, band):
    lo, hi = band
    f = np.geomspace(lo / 10**DECADES, hi * 10**DECADES,
                     int(PER_DECADE * (np.log10(hi / lo) + 2 * DECADES)))
    lam = np.concatenate([np.asarray(nm.poles)] + (
        [] if nm.residual is None else [np.asarray(nm.residual.poles)]))
    z = -lam.real / np.abs(lam)
    near = np.abs(lam)[:, None] * (1 + np.outer(z, POLE_OFFSETS)) / (2 * np.pi)
    return np.unique(np.concatenate([f, near[near > 0].ravel(), _wings(lam, f)]))


def _wings(lam, f):
    """Points on the flanks of each pole: a lightly damped term's Hermitian part decays only
    as ``1 / (w0^2 - w^2)``, far beyond its half-power points; at ``zeta`` times
    :data:`WINGS` (relative) on either side, up to the log grid's own spacing."""
    step = float(np.median(np.diff(np.log(f)))) if f.size > 1 else 0.1
    z = np.maximum(-lam.real / np.abs(lam), 1e-12)
    rel = np.outer(z, WINGS)
    rel = np.where(rel < step, rel, np.nan)
    out = np.abs(lam)[:, None, None] * (1 + np.stack([rel, -rel], axis=2)) / (2 * np.pi)
    return out[np.isfinite(out) & (out > 0)]


def passive_at_pairs(nm, pairs, cm, refit: bool = True):
    """``nm`` made passive at the collocated ``pairs`` (module notes), its record in
    ``nm.properness.passivity``.

    Parameters
    ----------
    nm : NormalModeModel
        Built by ``normal_modes`` (its ``properness.band``), residual dynamics included.
    pairs : sequence of (int, int)
        Collocated (sensor, actuator) pairs.
    cm : ComplexModeModel
        The identified model: the refit is kept only while the normal-mode model stays as
        close to it as before or as ``cm.search.logls`` asks (:func:`_acceptable`).
    refit : bool
        False: the check alone (status ``"not passive"`` when it fails).

    Returns
    -------
    NormalModeModel
    """
    new, rec = _passive(nm, pairs, cm, refit)
    if rec is None:
        return nm
    return new.replace(properness=replace(new.properness, passivity=rec))


def _passive(nm, pairs, cm, refit):
    band = nm.properness.band if nm.properness is not None else None
    if not pairs or band is None:
        return nm, None
    pairs = tuple((int(i), int(a)) for i, a in pairs)
    grid = _grid(nm, band)
    Y = _collocated(nm.frf(grid, "velocity").H, pairs)
    worst = _worst(Y)
    rec = CollocatedPassivity(pairs=pairs, worst_before=float(worst.min()),
                              worst_after=float(worst.min()),
                              worst_frequency=float(grid[np.argmin(worst)]))
    if worst.min() >= -TOL and _asymptotes_passive(nm, pairs):
        return nm, rec
    if not refit:
        return nm, replace(rec, status="not passive")
    terms = _Terms(np.zeros(0, complex) if nm.residual is None else np.asarray(nm.residual.poles),
                   nm.E is not None, nm.F is not None)
    if terms.poles.size == 0 and not (terms.has_E or terms.has_F):
        return nm, replace(rec, status="nothing to refit")
    peak = max(float(np.abs(Y).max()), 1e-300)
    try:
        x, used, after = _solve(nm, pairs, terms, _Grid(grid, worst, peak))
    except _Failed as exc:
        return nm, replace(rec, status=str(exc))
    new = _with_blocks(nm, pairs, terms, x)
    f = np.linspace(band[0], band[1], FIT_LINES)           # the band, for both judgements
    H_old, H_new = nm.frf(f).H, new.frf(f).H
    rec = replace(rec, frequencies=used, fit_change=mean_logls(_collocated(H_new, pairs),
                                                               _collocated(H_old, pairs)))
    why = _acceptable(H_old, H_new, cm.frf(f).H, cm)
    if why:
        return nm, replace(rec, status=why)
    return new, replace(rec, worst_after=float(after.min()), refitted=True, status="refitted")


def _acceptable(old, new, ref, cm) -> str:
    """Empty when the refitted model's response ``new`` is as close to ``cm``'s (``ref``;
    mean logLS 3.12 over the band) as the model's own ``old`` was, or as the identified model is to
    its data (``cm.search.logls``, the closeness step 7 asks), to within :data:`FLOOR`; else why
    not.  Non-passivity that only a large change of these terms removes is needed by the
    fit in the band -- the normal modes' own (a damping matrix not positive definite,
    ``phib`` not ``cphi^T`` at a pair, 3.45) or a non-reciprocal ``F`` (its antisymmetric
    part turns the admittance non-passive as ``1/w`` below the band: the README's truss)
    -- and is left, reported."""
    before, after = mean_logls(old, ref), mean_logls(new, ref)
    target = cm.search.logls if cm.search is not None else None
    allowed = max(before, target or 0.0) + FLOOR
    if after <= allowed:
        return ""
    return (f"not refitted: the passive refit would move the model to {after:.3g} mean logLS "
            f"from the identified one (allowed {allowed:.3g}): what keeps it from passive "
            "is needed to fit the band (the normal modes' own damping or scaling, 3.45, or "
            "a non-reciprocal E or F)")


def _asymptotes_passive(nm, pairs) -> bool:
    """``E_cc`` and ``F_cc`` (symmetric parts) positive semi-definite (module notes)."""
    for X in (nm.E, nm.F):
        if X is not None:
            S = _collocated(np.asarray(X, float), pairs)
            ev = np.linalg.eigvalsh(0.5 * (S + S.T))
            if ev[0] < -TOL * max(float(np.abs(ev).max()), 1e-300):
                return False
    return True


class _Failed(Exception):
    """The semidefinite program gave no solution (its status as the message)."""


def _fit_points(band, grid):
    """The uniform lines of the band and the check grid's points inside it."""
    f = np.linspace(band[0], band[1], FIT_LINES)
    return np.unique(np.concatenate([f, grid[(grid >= band[0]) & (grid <= band[1])]]))


@dataclass(frozen=True, eq=False)
class _Grid:
    """The check's frequencies (Hz), the worst dip at each and the admittance's peak."""

    freq: np.ndarray
    worst: np.ndarray
    peak: float


def _maps(k: int, terms: _Terms):
    """``vec`` of each variable block from its unknowns: the residues' blocks ``A_j``,
    ``B_j`` in full (their antisymmetric parts may stay where passivity allows), ``E`` and
    ``F`` symmetric (an antisymmetric part would leave ``s E`` non-passive at infinity)."""
    full, sym = np.eye(k * k), _sym_map(k)
    return [full] * (2 * terms.poles.size) + [sym] * (terms.has_E + terms.has_F)


def _stacked(coef, maps):
    """(nf, k^2, nvar): the blocks' coefficients ``coef`` (nf, nb) times their maps."""
    return np.concatenate([coef[:, b, None, None] * m[None] for b, m in enumerate(maps)],
                          axis=2)


def _solve(nm, pairs, terms: _Terms, chk: _Grid):
    """The refitted blocks' unknowns by cutting planes, the constraint frequencies and the
    dips of the result on the check's grid; raises _Failed."""
    import cvxpy as cp

    k = len(pairs)
    maps = _maps(k, terms)
    grid = chk.freq
    # fit: weighted in-band response of the adjustable terms against their present one
    f = _fit_points(nm.properness.band, grid)
    level = np.abs(_collocated(nm.frf(f).H, pairs)).reshape(f.size, k * k)
    wgt = 1.0 / np.maximum(level, 1e-12 * level.max() + 1e-300)
    target = _collocated(_adjustable(nm, f), pairs).reshape(f.size, k * k) * wgt
    M = _stacked(_blocks(terms, 2 * np.pi * f, vel=False), maps) * wgt[:, :, None]
    A = np.concatenate([M.real, M.imag]).reshape(-1, M.shape[2])
    b = np.concatenate([target.real, target.imag]).ravel()
    top = np.where((top := np.abs(A).max(axis=0)) > 0, top, 1.0)    # norms without overflow
    d = 1.0 / (top * np.maximum(np.linalg.norm(A / top, axis=0), 1e-300))   # unknowns ~ 1
    Ad = A * d
    y = cp.Variable(A.shape[1])
    # ||A x - b||^2 = y'H y - 2 g'y + const: a quadratic objective, not a cone of nf rows
    # (sparse: the unknowns of different entries meet only through E's and F's symmetry)
    H = sps.csc_matrix(np.where(np.abs(G := Ad.T @ Ad) > 1e-14 * np.abs(G).max(), G, 0.0))
    objective = cp.Minimize(cp.quad_form(y, cp.psd_wrap(H)) - 2 * (Ad.T @ b) @ y)
    cons, col = [], 2 * terms.poles.size * k * k
    for m in maps[2 * terms.poles.size:]:                     # E, F positive semi-definite
        Mb = m * d[None, col:col + m.shape[1]]
        X = cp.reshape((Mb / np.abs(Mb).max()) @ y[col:col + m.shape[1]], (k, k), order="C")
        cons.append(0.5 * (X + X.T) >> 0)
        col += m.shape[1]
    used = np.union1d(_local_minima(grid, chk.worst, ADDED), _near_terms(terms, grid))
    spec = _Lmi(nm.replace(residual=None, E=None, F=None), pairs, terms, maps, chk.peak)
    for _ in range(ROUNDS):
        lmi = _lmis(cp, spec, used, y, d)
        prob = cp.Problem(objective, cons + lmi)
        try:
            prob.solve(solver=cp.CLARABEL, chordal_decomposition_enable=False)
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as exc:      # noqa: BLE001 -- the solver's panics are BaseException
            raise _Failed(f"solver failed ({type(exc).__name__}: {exc}); the model is "
                          "returned as it is") from None
        if y.value is None or prob.status not in ("optimal", "optimal_inaccurate"):
            raise _Failed(f"solver status {prob.status}")
        trial = _with_blocks(nm, pairs, terms, d * y.value)
        now = _worst(_collocated(trial.frf(grid, "velocity").H, pairs))
        if now.min() >= -TOL:
            break
        used = np.unique(np.concatenate([used, _local_minima(grid, now, ADDED)]))
    return d * y.value, used, now


def _near_terms(terms: _Terms, grid):
    """Points of ``grid`` nearest each adjustable pole's resonance, half-power points and
    flanks, where a refitted term turns non-passive first (fewer cutting-plane rounds)."""
    lam = terms.poles
    if lam.size == 0:
        return np.zeros(0)
    z = -lam.real / np.abs(lam)
    f = np.abs(lam)[:, None] * (1 + np.outer(z, (-1.0, 0.0, 1.0))) / (2 * np.pi)
    f = np.concatenate([f[f > 0], _wings(lam, grid)])
    return np.unique(grid[np.abs(grid[:, None] - f[None, :]).argmin(axis=0)])


def _local_minima(grid, worst, n):
    """Up to ``n`` frequencies of ``grid`` at the lowest local minima of ``worst`` below 0."""
    v = np.concatenate([[np.inf], worst, [np.inf]])
    m = np.flatnonzero((v[1:-1] <= v[:-2]) & (v[1:-1] <= v[2:]) & (worst < 0))
    return np.sort(grid[m[np.argsort(worst[m])[:n]]])


@dataclass(frozen=True, eq=False)
class _Lmi:
    """What the LMIs at a frequency are built from: the normal modes alone (``base``), the
    pairs, the adjustable terms, their unknowns' maps and the admittance's peak."""

    base: object
    pairs: tuple
    terms: _Terms
    maps: list
    peak: float


def _lmis(cp, spec: _Lmi, freq, y, d):
    """The Hermitian part ``S + jK`` of the collocated admittance PSD at ``freq``, as the
    real ``[[S, -K], [K, S]] >> 0``, affine in the unknowns ``x = d y``; each LMI scaled
    to entries of order one (the data's unit does not reach the solver)."""
    k = len(spec.pairs)
    if freq.size == 0:
        return []
    Hm = _collocated(spec.base.frf(freq, "velocity").H, spec.pairs) / spec.peak
    Hh = 0.5 * (Hm + np.conj(np.swapaxes(Hm, -1, -2)))
    L = _stacked(_blocks(spec.terms, 2 * np.pi * freq, vel=True) / spec.peak, spec.maps)
    T = np.arange(k * k).reshape(k, k).T.ravel()                 # vec(X^T) = vec(X)[T]
    out = []
    for g in range(freq.size):
        Ls = 0.5 * (L[g].real + L[g].real[T]) * d[None, :]       # Re(c) sym(X)
        Lk = 0.5 * (L[g].imag - L[g].imag[T]) * d[None, :]       # Im(c) skew(X)
        top = max(np.abs(Ls).max(), np.abs(Lk).max(), np.abs(Hh[g]).max(), 1e-300)
        S = cp.reshape(Ls / top @ y, (k, k), order="C") + Hh[g].real / top
        K = cp.reshape(Lk / top @ y, (k, k), order="C") + Hh[g].imag / top
        Z = cp.bmat([[S, -K], [K, S]])
        out.append(0.5 * (Z + Z.T) >> 0)
    return out


def _adjustable(nm, f):
    """Displacement FRF of the residual dynamics, E and F of ``nm`` at ``f`` (Hz)."""
    from sdctrl.identification._complex_modes import frf_array

    shape = (nm.ns, nm.na)
    r = nm.residual
    lam = np.zeros(0, complex) if r is None else np.asarray(r.poles)
    R = np.zeros((0, *shape), complex) if r is None else np.asarray(r.residues)
    E = np.zeros(shape) if nm.E is None else np.asarray(nm.E)
    return frf_array(lam, R, E, nm.F, 2j * np.pi * f)


def _with_blocks(nm, pairs, terms: _Terms, x):
    """``nm`` with the collocated blocks of its adjustable terms from the unknowns ``x``."""
    k = len(pairs)
    si, ai = [i for i, _ in pairs], [a for _, a in pairs]
    blocks, col = [], 0
    for m in _maps(k, terms):
        blocks.append((m @ x[col:col + m.shape[1]]).reshape(k, k))
        col += m.shape[1]
    out = {}
    if terms.poles.size:
        R = np.array(nm.residual.residues)
        for j in range(terms.poles.size):
            R[j][np.ix_(si, ai)] = blocks[2 * j] - 1j * blocks[2 * j + 1]
        out["residual"] = replace(nm.residual, residues=R)
    b = 2 * terms.poles.size
    for name, has in (("E", terms.has_E), ("F", terms.has_F)):
        if has:
            X = np.array(getattr(nm, name), float)
            X[np.ix_(si, ai)] = blocks[b]
            out[name] = X
            b += 1
    return nm.replace(**out)
