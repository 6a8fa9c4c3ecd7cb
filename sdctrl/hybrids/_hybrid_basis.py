"""The shapes of a hybrid model and its residual terms (thesis 5.1.1, beyond it).

:func:`sdctrl.hybrid` assembles, from the FE model and the identified normal modes:

- the *expanded* measured shapes (4.7), on a basis richer than the paired FE modes (all FE
  modes down to a quarter of the lowest paired eigenvalue and up to ``fmax``, plus the
  static shapes of the test inputs), regularised toward the paired FE mode
  (:func:`sdctrl.hybrids._expansion.expand_regularised`) -- or, with
  ``expansion="paired"``, the thesis's least-squares fit on the paired modes only;
- the *low* FE modes (suspension or rigid-body modes well below the measured ones), kept
  as FE shapes; their modal masses can be corrected (a symmetric matrix ``P`` on their
  coordinates) to the identified residual mass ``F`` of the test;
- the other FE modes up to ``fmax`` (*appended*, 5.1.1), made mass-orthogonal to the
  expanded shapes, with the FE frequencies times one factor ``kappa``, the median ratio of
  measured to paired FE frequencies (the FE's global stiffness-to-mass error, which moves
  the unmeasured modes as it moved the measured ones);
- the static correction of the test inputs (2.21), consistent with those shapes
  (:func:`sdctrl.fe._static.consistent_static_modes`);
- the identified residual flexibility ``E`` kept, less what the appended modes already
  give at the test I/O (a constant fitted over the band).

Which of ``kappa`` and the residual fits is used is decided by the data: each variant is
compared with the identified model at the tested I/O (logLS over the band) and the closest
is kept (:func:`select_residual`); the wrong FE's modes never replace the test's residual
terms unless they reproduce them better.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from sdctrl.fe._static import consistent_static_modes
from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.updating._costs import logls
from sdctrl.hybrids._expansion import expand, expand_regularised, loo_prior
from sdctrl.hybrids._residual_mass import mass_bounded, mass_solve, mass_system

__all__ = ["HybridBasis", "ModeSet", "band_lines", "build_basis", "fe_modes_upto",
           "select_residual", "stack_parts", "tested_offset"]

#: low FE modes: eigenvalue below this fraction of the lowest paired FE eigenvalue
LOW_FRACTION = 0.25
#: appended FE modes almost inside the span of the expanded shapes are dropped
APPENDED_MIN_NORM = 0.1
#: frequency lines of the residual fits and of the selection
N_GRID = 200


def fe_modes_upto(fe, fmax: float, nmin: int):
    """FE modes (Hz, shapes) up to ``fmax`` Hz, at least ``nmin`` of them.

    Parameters
    ----------
    fe : FEModel
        The model.
    fmax : float
        Highest frequency (Hz).
    nmin : int
        Minimum number of modes (the measured modes to pair).

    Returns
    -------
    f : ndarray, shape (m,)
        Frequencies (Hz), increasing.
    phi : ndarray, shape (N, m)
        Mass-normalised shapes.

    Raises
    ------
    ValueError
        The FE model has fewer modes (DOFs) than ``nmin``.
    """
    if fe.N < nmin:
        raise ValueError(f"fe has {fe.N} DOFs, hence {fe.N} modes, fewer than the {nmin} "
                         f"measured modes of nm: every measured mode needs its own FE mode "
                         f"to pair with (give a finer FE model or fewer modes in nm)")
    n = min(fe.N, max(nmin, 20))
    while True:
        f, phi = fe.modes(n)
        if f[-1] >= fmax or n >= fe.N:
            break
        n = min(fe.N, 2 * n)
    keep = max(nmin, int(np.searchsorted(f, fmax, side="right")))
    return f[:keep], phi[:, :keep]


class HybridBasis:
    """The parts of a hybrid model that do not depend on the residual variant.

    Attributes
    ----------
    expanded : ndarray, shape (N, n)
        Expanded measured shapes.
    A : ndarray, shape (m, n)
        Expansion coefficients on :attr:`basis_kind` vectors.
    low, low_w2 : ndarray
        Low FE modes (N, kl) and their ``omega^2``.
    appended, appended_w2 : ndarray
        Appended FE modes (N, ka), mass-orthogonal to the expanded ones, and their FE
        ``omega^2`` (before ``kappa``).
    static, static_w2 : ndarray
        Static correction of the test inputs (N, ks) and ``omega^2``.
    kappa : float
        Median ratio of measured to paired FE frequencies.
    appended_test_w2, appended_test_zeta : ndarray, shape (ka,), or None
        Measured ``omega^2`` and damping ratio of the appended modes the test kept as
        residual dynamics, NaN for the others (:mod:`sdctrl.hybrids._measured_residual`,
        set by the hybrid).
    """

    def __init__(self, **parts):
        self.__dict__.update(parts)


def build_basis(fe, w2_id, cphi, c, loads, f_fe, phi_fe, pair,
                expansion: str = "regularised", prior=None, response=None) -> HybridBasis:
    """Expanded, low, appended and static shapes of a hybrid model.

    Parameters
    ----------
    fe : FEModel
        The analytical model.
    w2_id : ndarray, shape (n,)
        Measured ``omega^2`` (rad/s)^2.
    cphi : ndarray, shape (ns, n)
        Identified observabilities.
    c : ndarray, shape (ns, N)
        Test sensors on the FE DOFs.
    loads : ndarray, shape (N, na), or None
        Test input shapes (static shapes of the basis and of the model), if known.
    f_fe : ndarray, shape (m,)
        FE frequencies (Hz) up to ``fmax``.
    phi_fe : ndarray, shape (N, m)
        FE modes.
    pair : ndarray of int, shape (n,)
        FE mode paired with each measured mode.
    expansion : {"regularised", "paired"}
        Rich regularised basis, or the thesis's fit (4.7) on the paired modes.
    prior : tuple of ndarray, optional
        ``(spread, noise)`` per mode of the regularised expansion; default chosen by
        leave-one-sensor-out cross-validation (:func:`~sdctrl.hybrids._expansion.loo_prior`).
        Given, it is reused: the folds of ``residual="auto"`` that hold out an actuator keep
        the sensors and ``cphi``, hence the prior.
    response : ndarray, shape (N, na), optional
        ``K^-1 loads`` (4.23) when the caller has it: both static corrections below (the
        expansion basis's and the model's, 2.21) and the folds of ``residual="auto"`` then
        share one solve; computed here otherwise (equal to round-off).

    Returns
    -------
    HybridBasis
        With ``prior`` the ``(spread, noise)`` used (None for ``"paired"``).
    """
    lam_fe = (2 * np.pi * f_fe) ** 2
    low = lam_fe < LOW_FRACTION * lam_fe[pair].min()
    low[pair] = False
    if expansion == "paired":
        shapes, A = expand(phi_fe[:, pair], c, cphi)
        prior = None
    else:
        T, lam_T = phi_fe[:, ~low], lam_fe[~low]
        if loads is not None:                             # static correction (2.21)
            if response is None:
                response = fe.static_response(loads)
            V, wc2 = consistent_static_modes(fe, loads, phi_fe, response=response)
            T, lam_T = np.hstack([T, V]), np.concatenate([lam_T, wc2])
        where = np.cumsum(~low) - 1                       # index of FE mode k in T
        if prior is None:
            prior = loo_prior(c @ T, lam_T, cphi, where[pair])
        shapes, A = expand_regularised(T, lam_T, c, cphi, where[pair], spread=prior[0],
                                       noise=prior[1])
    app = np.setdiff1d(np.flatnonzero(~low), pair)
    Sa, wa2 = _orthogonal_to(fe, phi_fe[:, app], lam_fe[app], shapes)
    Sl, wl2 = phi_fe[:, low], lam_fe[low]
    if loads is not None:
        Vs, ws2 = consistent_static_modes(fe, loads, np.hstack([shapes, Sl, Sa]),
                                          response=response)
    else:
        Vs, ws2 = np.zeros((fe.N, 0)), np.zeros(0)
    ratio = np.sqrt(np.clip(w2_id, 0, None)) / (2 * np.pi * f_fe[pair])
    return HybridBasis(expanded=shapes, A=A, low=Sl, low_w2=wl2, appended=Sa, appended_w2=wa2,
                       static=Vs, static_w2=ws2, kappa=float(np.median(ratio)),
                       low_index=np.flatnonzero(low), appended_index=app, prior=prior,
                       appended_test_w2=None, appended_test_zeta=None)


def _orthogonal_to(fe, X, w2, S):
    """Columns of ``X`` made mass-orthogonal to ``S`` and normalised; near-dependent ones
    (residual mass norm below :data:`APPENDED_MIN_NORM`) dropped."""
    if not X.shape[1]:
        return X, w2
    MS = np.asarray(fe.M @ S)
    R = X - S @ np.linalg.solve(S.T @ MS, MS.T @ X)
    nrm = np.sqrt(np.clip(np.einsum("ij,ij->j", R, np.asarray(fe.M @ R)), 0, None))
    keep = nrm > APPENDED_MIN_NORM
    return R[:, keep] / nrm[keep], w2[keep]


# ----------------------------------------------------------------------------------------
# residual terms at the tested I/O
# ----------------------------------------------------------------------------------------
def band_lines(nm, w_id):
    """Frequency lines (rad/s) of the test band: ``nm.properness.band`` or the measured
    modes' range."""
    band = None if nm.properness is None else nm.properness.band
    if band is None:
        band = (0.8 * w_id.min() / (2 * np.pi), 1.05 * w_id.max() / (2 * np.pi))
    lo, hi = float(band[0]), float(band[1])
    lo = max(lo, 1e-3 * hi)
    return 2 * np.pi * np.linspace(lo, hi, N_GRID)


def _modal_frf(cphi, w2, gamma, phib, w):
    """Displacement FRF (nw, ns, na) of uncoupled modes (diagonal damping ``gamma``)."""
    d = w2[None, :] - w[:, None] ** 2 + 1j * w[:, None] * gamma[None, :]
    return np.einsum("ik,wk,kj->wij", cphi, 1.0 / d, phib, optimize=True)


def select_residual(nm, kept, base: HybridBasis, c, phib_measured, loads, zeta: float,
                    mode: str = "identified"):
    """Residual variant (``kappa``, low-mode mass correction, kept ``E``) closest to ``nm``.

    Each variant is assembled (:func:`assemble`) and compared with the identified model at
    the tested I/O (logLS of the displacement FRFs over the band); the closest wins.  With
    no residual information in ``nm`` (no ``E``, no ``F``, nothing absorbed) ``kappa`` is
    used without fits.

    Parameters
    ----------
    nm : NormalModeModel
        The identified model (all its modes, ``E``, ``F``).
    kept : ndarray of bool, shape (nm.n,)
        Measured modes kept in the hybrid (the others are absorbed into residual terms).
    base : HybridBasis
        Shapes of the hybrid.
    c : ndarray, shape (ns, N)
        Test sensors.
    phib_measured : ndarray, shape (n_kept, na)
        Controllabilities of the kept measured modes.
    loads : ndarray, shape (N, na), or None
        Physical test inputs (controllability of the other modes).
    zeta : float
        Damping ratio of the appended FE modes.
    mode : {"identified", "fe"}
        ``"fe"``: the thesis's hybrid (FE frequencies, no residual terms).

    Returns
    -------
    parts : dict
        Inputs of :func:`assemble` of the chosen variant.
    report : dict
        ``{"variant": name, "scores": {name: logLS}, "kappa": float}``.
    """
    w_id = np.sqrt(np.clip(np.diag(nm.Omega), 0, None))
    w = band_lines(nm, w_id[kept])
    Href = nm.frf(w / (2 * np.pi)).H
    kept_modal = _sub(nm, kept)
    R_t = Href - kept_modal.frf(w / (2 * np.pi)).H
    has_info = nm.E is not None or nm.F is not None or not np.all(kept)
    kappas = [base.kappa] if abs(base.kappa - 1) > 1e-9 else [1.0]
    if mode == "fe":
        variants = [("fe", 1.0, "none")]
    elif not has_info or loads is None:
        variants = [("kappa", kappas[0], "none")]
    else:
        kappas = kappas + ([1.0] if kappas[0] != 1.0 else [])
        variants = [(f"{'kappa' if k != 1.0 else 'fe frequencies'}, {fit}", k, fit)
                    for k in kappas for fit in ("mass+E", "E", "none")]
    scores, best = {}, None
    data = _VariantData(kept_modal, base, c, phib_measured, loads, zeta, w, R_t, Href)
    for name, kap, fit in variants:
        parts = _variant(data, kap, fit, measured=mode != "fe")
        if len(variants) == 1:
            return parts, {"variant": name, "scores": {}, "kappa": kap}
        model = assemble(kept_modal, parts, c, loads)
        scores[name] = logls(model.frf(w / (2 * np.pi)).H, Href)
        if best is None or scores[name] < scores[best[0]]:
            best = (name, parts, kap)
    return best[1], {"variant": best[0], "scores": scores, "kappa": best[2]}


def _sub(nm, keep):
    """``nm`` restricted to the modes ``keep`` (no residual terms)."""
    k = np.flatnonzero(keep)
    return NormalModeModel(nm.Omega[np.ix_(k, k)], nm.Gamma[np.ix_(k, k)], nm.cphi[:, k],
                           nm.phib[k], sensors=nm.sensors, actuators=nm.actuators)


@dataclass(frozen=True, eq=False)
class _VariantData:
    """What every residual variant of :func:`select_residual` is built from.

    ``kept_modal`` the kept measured modes, ``base`` the shapes, ``c`` the test sensors,
    ``phib_meas`` the measured controllabilities, ``loads`` the test inputs (or None),
    ``zeta`` the appended modes' damping ratio, ``w`` the lines (rad/s), ``R_t`` what the
    kept measured modes leave of the identified FRF ``Href`` there.
    """

    kept_modal: NormalModeModel
    base: HybridBasis
    c: np.ndarray
    phib_meas: np.ndarray
    loads: np.ndarray | None
    zeta: float
    w: np.ndarray
    R_t: np.ndarray
    Href: np.ndarray

    @cached_property
    def mass(self):
        """Normal equations of the low modes' mass fit (:func:`mass_system`): the same for
        every variant (``kappa`` moves only the target), formed once."""
        Sl, W = self.base.low, _weights(self.Href)
        return mass_system(self.c @ Sl, Sl.T @ self.loads, self.base.low_w2, self.zeta,
                           self.w, W)


def _weights(Href):
    """Inverse squared magnitudes of the identified FRF (the logLS-like fit weights)."""
    return 1.0 / np.maximum(np.abs(Href), 1e-300 * np.abs(Href).max()) ** 2


def _variant(data: _VariantData, kap: float, fit: str, measured: bool = True):
    """Shapes, frequencies, damping and ``E`` of one residual variant (``kappa``, fit);
    ``measured``: appended modes the test measured take its frequency (not for ``"fe"``)."""
    kept_modal, base, c, loads, zeta = data.kept_modal, data.base, data.c, data.loads, data.zeta
    w, R_t, Href = data.w, data.R_t, data.Href
    Sl, wl2 = base.low, base.low_w2
    wa2, za = base.appended_w2 * kap**2, np.full(base.appended_w2.shape, zeta)
    if measured and base.appended_test_w2 is not None:
        wa2 = np.where(np.isnan(base.appended_test_w2), wa2, base.appended_test_w2)
        za = np.where(np.isnan(base.appended_test_zeta), za, base.appended_test_zeta)
    parts = {"measured": (base.expanded, np.diag(kept_modal.Omega), kept_modal.Gamma,
                          data.phib_meas),
             "low": (Sl, wl2), "appended": (base.appended, wa2),
             "static": (base.static, base.static_w2), "zeta": zeta, "appended_zeta": za,
             "E": None,
             "measured_offset": kept_modal.cphi - c @ base.expanded}
    if fit == "none" or loads is None:
        return parts
    # what the fixed appended and static modes give at the tested I/O
    Ha = np.zeros_like(R_t)
    for S, w2, z in ((base.appended, wa2, za), (base.static, base.static_w2, 1.0)):
        if S.shape[1]:
            gam = 2 * np.sqrt(w2) * z
            Ha = Ha + _modal_frf(c @ S, w2, gam, S.T @ loads, w)
    target = R_t - Ha
    W = _weights(Href)
    cl = c @ Sl
    if fit == "mass+E" and Sl.shape[1]:
        P = mass_bounded(mass_solve(data.mass, target))
        # carried, like E, by the low modes' observabilities at the tested sensors: the
        # low FE shapes (and their prediction at other DOFs) are left as they are
        parts["low_offset"] = cl @ (P - np.eye(P.shape[0]))
        cl = cl @ P
        parts["mass_correction"] = np.linalg.eigvalsh(P)
    if Sl.shape[1]:
        target = target - _modal_frf(cl, wl2, 2 * zeta * np.sqrt(wl2), Sl.T @ loads, w)
    parts["E"] = np.sum(W * target.real, axis=0) / np.sum(W, axis=0)
    return parts


def tested_offset(parts, ns: int) -> np.ndarray:
    """What the tested sensors' observabilities hold beyond ``c @ shapes``.

    The identified residual-mass correction of the low modes (``"mass+E"``) is carried at
    the tested sensors only, as the residual flexibility ``E`` is (2.22): ``c S_l P``
    instead of ``c S_l`` for the low modes.  Columns in the order of :func:`stack_parts`.

    Parameters
    ----------
    parts : dict
        From :func:`select_residual`.
    ns : int
        Number of tested sensors.

    Returns
    -------
    ndarray, shape (ns, n)
    """
    sizes = [parts["measured"][0].shape[1]] + [parts[k][0].shape[1]
                                                for k in ("low", "appended", "static")]
    off = np.zeros((ns, sum(sizes)))
    if parts.get("measured_offset") is not None:
        off[:, :sizes[0]] = parts["measured_offset"]
    if parts.get("low_offset") is not None:
        off[:, sizes[0]:sizes[0] + sizes[1]] = parts["low_offset"]
    return off


@dataclass(frozen=True, eq=False)
class ModeSet:
    """The modes of a hybrid model being assembled, one column (entry) per mode.

    Attributes
    ----------
    shapes : ndarray, shape (N, n)
        Shapes on the FE DOFs.
    w2 : ndarray, shape (n,)
        ``omega^2`` (rad/s)^2.
    Gamma : ndarray, shape (n, n)
        Modal damping (rad/s).
    phib : ndarray, shape (n, na)
        Modal controllability.
    kind : ndarray of str, shape (n,)
        ``"measured"``, ``"fe"``, ``"residual"`` or ``"static"``.
    offset : ndarray, shape (ns, n)
        What the tested sensors' observabilities hold beyond ``c @ shapes``
        (:func:`tested_offset`).
    """

    shapes: np.ndarray
    w2: np.ndarray
    Gamma: np.ndarray
    phib: np.ndarray
    kind: np.ndarray
    offset: np.ndarray

    def sorted(self) -> ModeSet:
        """The same modes in increasing frequency (stable order).

        Returns
        -------
        ModeSet
        """
        o = np.argsort(self.w2, kind="stable")
        return ModeSet(self.shapes[:, o], self.w2[o], self.Gamma[np.ix_(o, o)], self.phib[o],
                       self.kind[o], self.offset[:, o])


def assemble(kept_modal, parts, c, loads):
    """Normal-mode model (no shapes' DOF labels) of one variant, for its comparison.

    Parameters
    ----------
    kept_modal : NormalModeModel
        The kept measured modes (labels).
    parts : dict
        From :func:`select_residual`.
    c : ndarray, shape (ns, N)
        Test sensors.
    loads : ndarray, shape (N, na), or None
        Test inputs.

    Returns
    -------
    NormalModeModel
        Modes in the order measured, low, appended, static.
    """
    m = stack_parts(parts, loads, c.shape[0])
    return NormalModeModel(np.diag(m.w2), m.Gamma, c @ m.shapes + m.offset, m.phib, E=parts["E"],
                           sensors=kept_modal.sensors, actuators=kept_modal.actuators)


def stack_parts(parts, loads, ns: int) -> ModeSet:
    """Shapes, ``omega^2``, block-diagonal ``Gamma``, ``phib``, kinds and offsets of a variant.

    Parameters
    ----------
    parts : dict
        From :func:`select_residual`.
    loads : ndarray, shape (N, na), or None
        Test inputs (controllability of the non-measured modes; zero when unknown).
    ns : int
        Number of tested sensors.

    Returns
    -------
    ModeSet
        Modes in the order measured, low, appended, static.
    """
    Sm, w2m, Gm, pbm = parts["measured"]
    blocks = [(Sm, w2m, Gm, "measured")]
    for key, kind, ratio in (("low", "fe", parts["zeta"]),
                             ("appended", "fe", parts["appended_zeta"]),
                             ("static", "residual", 1.0)):      # static: critically damped
        S, w2 = parts[key]
        blocks.append((S, w2, np.diag(2 * ratio * np.sqrt(np.clip(w2, 0, None))), kind))
    shapes = np.hstack([b[0] for b in blocks])
    w2 = np.concatenate([b[1] for b in blocks])
    n = shapes.shape[1]
    Gamma = np.zeros((n, n))
    i0 = 0
    for blk in blocks:
        k = blk[2].shape[0]
        Gamma[i0:i0 + k, i0:i0 + k] = blk[2]
        i0 += k
    kinds = np.concatenate([np.full(b[0].shape[1], b[3]) for b in blocks])
    phib = np.zeros((n, pbm.shape[1]))
    phib[:Sm.shape[1]] = pbm
    if loads is not None:
        phib[Sm.shape[1]:] = shapes[:, Sm.shape[1]:].T @ loads
    return ModeSet(shapes, w2, Gamma, phib, kinds, tested_offset(parts, ns))
