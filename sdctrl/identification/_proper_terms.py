"""The terms of a normal-mode model built from proper complex modes (thesis 3.3): the
asymptotic terms ``E`` and ``F`` kept when not negligible (3.7), the real input shapes
``phib`` fitted to the residues, then, for close modes, to the identified FRF relative to
its level (:func:`fitted_to_frf`), the residues of the result and the check of its poles against the
identified ones (steps 4-5 of :func:`sdctrl.normal_modes`).

Internal module: the functions trust their inputs (validated by ``normal_modes``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sdctrl.identification._close_modes import close_groups
from sdctrl.identification._complex_modes import frf_array
from sdctrl.identification._normal_statistics import with_std

__all__ = ["asymptotic_terms", "fitted_to_frf", "model_residues", "phib_from_residues",
           "pole_error"]

#: lines of the uniform grid over the band on which :func:`fitted_to_frf` fits ``phib``
GRID_LINES = 400
#: and, around each mode, points at these multiples of its half-power half-bandwidth ``-Re l``
POLE_OFFSETS = (-3.0, -1.0, -0.5, 0.0, 0.5, 1.0, 3.0)


def asymptotic_terms(E, F, lam, R, rtol: float = 1e-10):
    """``E`` and ``F`` of the complex-mode model, None when negligible (round-off of a fit),
    and their relative sizes (``E_relative_size``, ``F_relative_size``).

    ``E`` is compared with the off-resonance flexibility scale of the modes,
    ``max_j max|R_j| / |lambda_j|``, and ``F`` through ``F / w^2`` at the lowest pole; a
    negligible ``F`` would otherwise add needless rigid-body states (2.24) to the
    state-space form.
    """
    ref = max(float(np.max(np.abs(R).max(axis=(1, 2)) / np.abs(lam))), 1e-300)
    wmin = float(np.abs(lam).min())
    out, sizes = [], {}
    for name, X, scale in (("E", E, 1.0), ("F", F, wmin**-2)):
        size = float(np.abs(X).max()) * scale if X is not None and np.size(X) else 0.0
        keep = size > rtol * ref
        sizes[f"{name}_relative_size"] = size / ref
        out.append(np.array(X, float) if keep else None)
    return out, sizes


def phib_from_residues(R: np.ndarray, cpsi_p: np.ndarray, Psi: np.ndarray) -> np.ndarray:
    """Real ``phib`` minimising ``sum_j ||R_j - cpsi_j Psi_j^T phib||^2`` (linear LS)."""
    n, ns, na = R.shape
    D = np.einsum("ij,kj->jik", cpsi_p, Psi).reshape(n * ns, Psi.shape[0])
    rhs = R.reshape(n * ns, na)
    A = np.vstack([D.real, D.imag])
    b = np.vstack([rhs.real, rhs.imag])
    return np.linalg.lstsq(A, b, rcond=None)[0]


def model_residues(cphi: np.ndarray, Psi: np.ndarray, phib: np.ndarray) -> np.ndarray:
    """Residues ``cphi Psi_j Psi_j^T phib`` of a normal-mode model, shape (n, ns, na)."""
    return np.einsum("ij,jk->jik", cphi @ Psi, Psi.T @ phib)


def pole_error(p_model: np.ndarray, p_id: np.ndarray) -> float:
    """Max relative distance of each identified pole to the model's matching pole."""
    from scipy.optimize import linear_sum_assignment

    p_model = p_model[p_model.imag > 0]
    if p_model.size != p_id.size:
        return float("inf")
    cost = np.abs(p_id[:, None] - p_model[None, :]) / np.abs(p_id)[:, None]
    r, c = linear_sum_assignment(cost)
    return float(cost[r, c].max()) if r.size else 0.0


def fitted_to_frf(cm, nm, sel, improper, steps=None):
    """Step 6 of :func:`sdctrl.normal_modes`: the rows of ``phib`` of close modes refitted to
    the identified FRF relative to its level, and the kept improper parts recomputed for it.

    The residues of close modes (:func:`~sdctrl.identification._close_modes.close_groups`)
    are determined by the test much less well than their sum, and a small transfer is the
    near-cancellation of their large contributions: the residue fit of step 5
    (:func:`phib_from_residues`), dominated by the largest entries of each residue, keeps
    every residue within its noise and still shifts the anti-resonances of the small
    transfers (the truss's close pair at 15.8/15.9 Hz).  The logLS cost (3.12) that judges
    the model weighs every level alike; its linearisation ``|H_nm / H - 1|^2`` (``H`` the
    identified FRF, 3.7) is a weighted least squares, linear in ``phib``, on
    :data:`GRID_LINES` lines over the band and :data:`POLE_OFFSETS` around each pole.  Only
    the rows of the close modes whose improper parts are not kept change (the others keep
    the residue fit, whose collocation ``phib[:, a] ~ cphi[s]`` the hybrid models build on,
    5.1): the fit is on the contributions (2.9, one pole each) of the modes whose parts are
    not kept against the identified model's at those poles -- the kept ones reproduce their
    identified residues whatever ``phib``; their improper parts are then the identified
    residues minus the new normal modes'.  Without a band (a model built from matrices) or
    without such a group, nothing changes.

    ``nm.std`` of the refitted rows is that of the refitted values (:func:`_refit_std`):
    the identification's statistics (3.56)-(3.59) propagated through the refit to first
    order (its grid and weights held), as
    :func:`~sdctrl.identification._normal_statistics.with_std` propagates them through
    steps 1-5 (3.4); the other entries of ``nm.std`` are those of steps 1-5.

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model (displacement residues, band in Hz).
    nm : NormalModeModel
        Its normal modes (poles ``sel``), ``phib`` from the residues (step 5).
    sel : ndarray of int
        Poles of ``cm`` made normal modes.
    improper : (ndarray of int, ndarray)
        :func:`~sdctrl.identification._mode_split.improper_terms` on ``nm``.
    steps : callable, optional
        ``ComplexModeModel -> NormalModeModel``, steps 1-5 that gave ``nm`` (no std): the
        std of the refitted rows is then propagated through them too (:func:`_refit_std`).

    Returns
    -------
    nm : NormalModeModel
        With the refitted rows of ``phib`` (``properness.residue_error`` and
        ``collocation_error`` updated).
    improper : (ndarray of int, ndarray)
        The same poles, their improper parts against the new normal modes.
    """
    idx = improper[0]
    sel = np.asarray(sel, int)
    lam, R = np.asarray(cm.poles)[sel], np.asarray(cm.residues)[sel]
    free = ~np.isin(sel, idx)
    group = close_groups(lam)
    grouped = free & np.isin(group, group[group != np.arange(sel.size)])
    if cm.band is None or not grouped.any():
        return nm, improper
    fit = _Refit(nm, sel, free, _rows(nm, lam[grouped]))   # the normal modes of the groups
    phib = fit.phib(cm)
    new = nm.replace(phib=phib, std=_refit_std(nm, cm, fit, steps))
    X, Y = fit.factors(lam)
    Rn = np.einsum("ij,jk->jik", X, Y.T @ phib)
    p = nm.properness
    record = replace(
        p, residue_error=float(np.linalg.norm(Rn - R) / max(np.linalg.norm(R), 1e-300)),
        collocation_error=max(float(np.linalg.norm(phib[:, a] - new.cphi[i])
                                    / max(np.linalg.norm(new.cphi[i]), 1e-300))
                              for i, a in p.collocated))
    keep = np.isin(sel, idx)
    order = np.argsort(sel[keep])
    return new.replace(properness=record), (sel[keep][order], (R - Rn)[keep][order])


@dataclass(frozen=True, eq=False)
class _Refit:
    """The step-6 refit of :func:`fitted_to_frf` with its choices fixed: the normal modes of
    steps 1-5 ``nm``, the poles ``sel`` of the identified model they stand for, those whose
    improper parts are not kept (``free``, mask on ``sel``) and the rows of ``phib`` refitted."""

    nm: object
    sel: np.ndarray
    free: np.ndarray
    rows: np.ndarray
    #: frequencies (rad/s, imaginary) and weights ``1/|H|`` (nf, ns, na) held fixed, or None:
    #: from the identified model fitted
    grid: np.ndarray | None = None
    weight: np.ndarray | None = None

    def held(self, cm) -> _Refit:
        """This refit with the grid and weights of ``cm`` held (:func:`_refit_std`)."""
        s = self._grid(cm, np.asarray(cm.poles)[self.sel])
        return replace(self, grid=s, weight=self._weight(cm, s))

    def _grid(self, cm, lam):
        if self.grid is not None:
            return self.grid
        lo, hi = 2 * np.pi * np.asarray(cm.band, float)
        w = np.concatenate([np.linspace(lo, hi, GRID_LINES),
                            (lam.imag[:, None] - lam.real[:, None] * POLE_OFFSETS).ravel()])
        return 1j * np.unique(w[(w >= lo) & (w <= hi)])

    def _weight(self, cm, s):
        if self.weight is not None:
            return self.weight
        zero = np.zeros((cm.ns, cm.na))
        mod = np.abs(frf_array(np.asarray(cm.poles), np.asarray(cm.residues),
                               zero if cm.E is None else np.asarray(cm.E), cm.F, s))
        return (1.0 / np.maximum(mod, 1e-12 * mod.max()) if mod.max() > 0
                else np.ones_like(mod))

    def factors(self, lam):
        """``X``, ``Y`` of the normal modes at the poles ``lam`` (2.9)."""
        from sdctrl.identification._mode_split import modal_factors

        return modal_factors(self.nm, lam)

    def phib(self, cm) -> np.ndarray:
        """``phib`` of ``nm`` with :attr:`rows` refitted to the FRF of ``cm``."""
        nm, free, rows = self.nm, self.free, self.rows
        lam, R = np.asarray(cm.poles)[self.sel], np.asarray(cm.residues)[self.sel]
        X, Y = self.factors(lam)                             # R_nm,j = X_j (Y_j^T phib)
        s = self._grid(cm, lam)
        zero = np.zeros((cm.ns, cm.na))
        target = frf_array(lam[free], R[free], zero, None, s)
        g = 1.0 / (s[:, None] - lam[free][None, :])
        gc = 1.0 / (s[:, None] - lam[free].conj()[None, :])
        Xg, Xc = X[None, :, free] * g[:, None, :], X[None, :, free].conj() * gc[:, None, :]
        Yf = Y[:, free]
        G = Xg @ Yf[rows].T + Xc @ Yf[rows].conj().T                 # (nf, ns, rows)
        weight = self._weight(cm, s)
        Yb = Yf.T @ nm.phib
        target = target - (Xg @ Yb + Xc @ Yb.conj())                  # what step 5 leaves
        phib = np.array(nm.phib)
        for a in range(cm.na):
            A = (G * weight[:, :, a, None]).reshape(-1, rows.size)
            b = (target[:, :, a] * weight[:, :, a]).ravel()
            phib[rows, a] += np.linalg.lstsq(np.vstack([A.real, A.imag]),
                                             np.concatenate([b.real, b.imag]), rcond=None)[0]
        return phib


def _refit_std(nm, cm, fit: _Refit, steps=None):
    """``nm.std`` with the rows of ``phib`` refitted by ``fit`` given the standard deviation
    of the refitted values; None stays None.

    The refit is a function of the identified poles and residues (the FRF (3.7) it fits and
    its weights) and of the normal modes of steps 1-5.  Its std is propagated the way every
    other entry of ``nm.std`` is (3.4): finite differences of the refit itself along the
    identified parameters ``[theta; C]`` and their covariance in block form (3.56)-(3.59),
    by :func:`~sdctrl.identification._normal_statistics.with_std` -- not the linearised
    least-squares covariance of the refit, which would treat the identified FRF's 400 lines
    as independent measurements (they are a smooth model of a few hundred noisy lines whose
    noise the statistics already carry).  The refit is differentiated with the normal modes
    of steps 1-5 it starts from (``steps``: ``cphi``, ``Omega``, ``Gamma``, the other rows of
    ``phib``, which move with the identified parameters too); the frequency grid and the
    weights ``1/|H|`` are held at their values (Gauss-Newton: the weights normalise the cost
    (3.12), their change acts through the fit's residual only, second order; differentiating
    them too overpredicted the std of the largest entries 1.7-1.8x on the truss at 1%).
    Holding the normal modes of steps 1-5 too (``steps`` None, before) underpredicted the
    refitted rows' scatter on the truss at 1% (12 draws, median / RMS of the entrywise
    ratios empirical / predicted): 1.42 / 1.40 on the unweighted fit, 2.39 / 2.44 on the
    level-weighted one that identify's default keeps there.  Calibration:
    tests/test_statistics_refit.py.  ``phib``'s other rows and every other entry keep the
    std of steps 1-5.

    Parameters
    ----------
    nm : NormalModeModel
        The normal modes of steps 1-5, with their std (3.4) or None.
    cm : ComplexModeModel
        The identified model (its ``statistics``).
    fit : _Refit
        The refit of step 6.
    steps : callable or None
        Steps 1-5 (``ComplexModeModel -> NormalModeModel``, no std); None holds ``fit.nm``.

    Returns
    -------
    dict or None
        ``nm.std`` with ``phib``'s rows ``fit.rows`` replaced.
    """
    if nm.std is None or cm.statistics is None:
        return nm.std
    fit = fit.held(cm)
    ref = nm.replace(phib=fit.phib(cm), std=None)

    def refitted(c):
        if steps is None:
            return ref.replace(phib=fit.phib(c))
        moved = steps(c)                          # its own mode signs: aligned by with_std
        return moved.replace(phib=replace(fit, nm=moved).phib(c))

    sd = with_std(ref, cm, refitted).std
    phib = np.array(nm.std["phib"])
    phib[fit.rows] = sd["phib"][fit.rows]
    return {**nm.std, "phib": phib}


def _rows(nm, poles) -> np.ndarray:
    """Index of the normal mode of ``nm`` matching each pole (by frequency, one to one)."""
    from scipy.optimize import linear_sum_assignment

    w = np.sqrt(np.clip(np.diag(nm.Omega), 0, None))
    r, c = linear_sum_assignment(np.abs(np.abs(poles)[:, None] - w[None, :]))
    return c[np.argsort(r)]
