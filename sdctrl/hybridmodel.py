"""Hybrid experimental/analytical models (thesis chapter V.1, eqs. 4.7, 5.1-5.4).

A test identifies, for the modes of its band, the modal frequencies ``Omega``, the
damping matrix ``Gamma`` and the modal observabilities ``(c phi)_ID`` at the sensors.  An
FE model gives shapes on all its DOFs, but less accurate frequencies and shapes.  The
hybrid model (5.1)

``I p'' + Gamma_c p' + Omega_c p = phi_c^T b_c u``, ``y = c_c phi_c p``

keeps the measured ``Omega``/``Gamma`` of the measured modes, uses the measured modes
*expanded* onto all FE DOFs (4.7), ``phi_Ex = phi_FE A`` with
``A = (c phi_FE)^+ (c phi)_ID``, and appends analytic FE modes below and above the test
band (an identified model covers only its band, and predictions for untested inputs
depend on what lies outside it), plus optional static correction modes.  Because its
shapes live on FE DOFs, the hybrid predicts untested sensors/actuators
(:func:`with_io`), modifications ``dM, dC, dK`` given on FE DOFs (5.2, :func:`modify`)
and D-strut loops (5.3)-(5.4) (:func:`strut_feedback`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
import scipy.sparse as sp

from sdctrl._validate import as_array
from sdctrl.fe.validation import io_shapes
from sdctrl.modal import NormalModeModel

__all__ = ["HybridModel", "expand", "hybrid", "modify", "pair_modes", "pairing_report",
           "strut_feedback", "with_io"]

#: MAC below which a FE/test pair is reported as poor (with a warning)
MAC_POOR = 0.8


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)      # the concise repr of NormalModeModel
class HybridModel(NormalModeModel):
    """Normal-mode model whose shapes live on FE DOFs (hybrid model 5.1).

    A :class:`~sdctrl.NormalModeModel` (same fields and methods) with the doors that need
    shapes on the DOFs of an FE model: :meth:`with_io` (untested inputs and outputs) and
    :meth:`modify` (modifications given on FE DOFs, 5.2).  :meth:`replace` keeps the
    class, so :meth:`modified`, :meth:`with_feedback` and :meth:`proportional` return
    hybrid models too.

    Parameters
    ----------
    Omega : array_like, shape (n, n)
        Modal stiffness (rad/s)^2.
    Gamma : array_like, shape (n, n)
        Modal damping (rad/s).
    cphi : array_like, shape (ns, n)
        Modal observability.
    phib : array_like, shape (n, na)
        Modal controllability.
    E : array_like, shape (ns, na), optional
        Static term of the displacement response.
    sensors, actuators : sequence of str, optional
        Output and input labels.
    shapes : array_like, shape (N, n), optional
        Mode shapes on the FE DOFs.
    dofs : sequence of str, optional
        FE DOF labels of the rows of ``shapes``.
    omega_c : float, optional
        Cut-off (rad/s) of the correction mode realising ``E`` in velocity/acceleration.
    F : array_like, shape (ns, na), optional
        Low-frequency (residual mass) correction ``F/s^2`` of the displacement response.
    """

    def replace(self, **changes) -> HybridModel:
        """Copy with some fields changed (validated again), keeping the class.

        Parameters
        ----------
        **changes
            New values of fields (``Omega``, ``Gamma``, ``cphi``, ``phib``, ``E``,
            ``sensors``, ``actuators``, ``shapes``, ``dofs``, ``omega_c``, ``info``, ...).

        Returns
        -------
        HybridModel
        """
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        kw.update(changes)
        return type(self)(**kw)

    def _repr_markdown_(self) -> str:
        md = super()._repr_markdown_()
        if self.info.get("pairing") is None:
            return md
        return md + "\n\n**FE/test mode pairing**\n\n" + pairing_report(self)

    def with_io(self, b=None, c=None, *, actuators=None, sensors=None) -> HybridModel:
        """Model with new inputs and/or outputs given on the FE DOFs; see :func:`with_io`.

        Parameters
        ----------
        b : array_like, shape (N, k), or DOF label(s), optional
            New input shapes (untested shakers); None keeps the inputs.
        c : array_like, shape (k, N), or DOF label(s), optional
            New output shapes (untested sensors); None keeps the outputs.
        actuators : sequence of str, optional
            Labels of the new inputs.
        sensors : sequence of str, optional
            Labels of the new outputs.

        Returns
        -------
        HybridModel
        """
        return with_io(self, b, c, actuators=actuators, sensors=sensors)

    def modify(self, dM=None, dC=None, dK=None) -> HybridModel:
        """Prediction after ``dM, dC, dK`` given on the FE DOFs (5.2); see :func:`modify`.

        Parameters
        ----------
        dM : array_like or sparse, shape (N, N), optional
            Mass modification on the DOFs of :attr:`shapes`.
        dC : array_like or sparse, shape (N, N), optional
            Damping modification.
        dK : array_like or sparse, shape (N, N), optional
            Stiffness modification.

        Returns
        -------
        HybridModel
        """
        return modify(self, dM, dC, dK)


# ----------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------
def _dof_rows(dofs: Sequence[str], labels, name: str) -> np.ndarray:
    """(N, k) point shapes of DOF labels on ``dofs``."""
    if dofs is None:
        raise ValueError(f"{name} given as DOF labels but the model has no dofs")
    labels = [labels] if isinstance(labels, str) else [str(v) for v in labels]
    index = {d: i for i, d in enumerate(dofs)}
    B = np.zeros((len(dofs), len(labels)))
    for j, lab in enumerate(labels):
        if lab not in index:
            raise ValueError(f"{name}: unknown DOF label {lab!r} (labels look like "
                             f"{dofs[0]!r})")
        B[index[lab], j] = 1.0
    return B


def _input_shapes(x, N: int, dofs, name: str):
    """(N, k) input shapes and labels (labels only when given as DOF labels)."""
    return io_shapes(x, N, lambda labels: _dof_rows(dofs, labels, name), name)


def _output_shapes(x, N: int, dofs, name: str):
    """(k, N) output shapes and labels."""
    return io_shapes(x, N, lambda labels: _dof_rows(dofs, labels, name), name, output=True)


def _check_fe(fe):
    from sdctrl.fe import FEModel

    if not isinstance(fe, FEModel):
        raise TypeError(f"fe must be an FEModel, got {type(fe).__name__}")


def _check_nm(nm, name: str = "nm"):
    if not isinstance(nm, NormalModeModel):
        raise TypeError(f"{name} must be a NormalModeModel, got {type(nm).__name__}")


# ----------------------------------------------------------------------------------------
# expansion and pairing
# ----------------------------------------------------------------------------------------
def expand(phi_fe, c, cphi_id, rcond: float = 1e-10):
    """Geometric expansion of measured modes onto all FE DOFs, eq. (4.7).

    ``A = argmin ||c phi_FE A - (c phi)_ID||_F = (c phi_FE)^+ (c phi)_ID`` and the
    expanded shapes are ``phi_Ex = phi_FE A``.  With more sensors than modes the
    pseudo-inverse smooths the measured observabilities towards the span of the FE
    shapes (section 4.1.1); the scaling of ``(c phi)_ID`` (mass normalisation of the true
    structure) is kept.

    Parameters
    ----------
    phi_fe : array_like, shape (N, m)
        FE mode shapes spanning the expansion (e.g. the FE modes paired with the test).
    c : array_like, shape (ns, N)
        Test sensors placed on the FE DOFs.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities (displacement sensors).
    rcond : float
        Relative cut-off of small singular values of ``c phi_FE`` in the pseudo-inverse.

    Returns
    -------
    shapes : ndarray, shape (N, n)
        Expanded shapes ``phi_FE A``.
    A : ndarray, shape (m, n)
        Combination coefficients.

    Examples
    --------
    >>> import numpy as np
    >>> phi = np.eye(4)[:, :2]
    >>> c = np.eye(4)[:3]
    >>> shapes, A = expand(phi, c, np.array([[1.0], [0.5], [0.0]]))
    >>> shapes.ravel().tolist()
    [1.0, 0.5, 0.0, 0.0]
    """
    P = as_array(phi_fe, "phi_fe", ndim=2)
    Cm = as_array(c, "c", ndim=2)
    Y = as_array(cphi_id, "cphi_id", ndim=2)
    if Cm.shape[1] != P.shape[0]:
        raise ValueError(f"c must have shape (ns, N={P.shape[0]}), got {Cm.shape}")
    if Y.shape[0] != Cm.shape[0]:
        raise ValueError(f"cphi_id must have shape (ns={Cm.shape[0]}, n), got {Y.shape}")
    A = np.linalg.pinv(Cm @ P, rcond=rcond) @ Y
    return P @ A, A


def pair_modes(cphi_fe, cphi_id):
    """Pair test modes with FE modes by maximal total MAC (4.9), one FE mode per test mode.

    Parameters
    ----------
    cphi_fe : array_like, shape (ns, m)
        FE modal observabilities at the test sensors, ``m >= n``.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities.

    Returns
    -------
    index : ndarray of int, shape (n,)
        FE mode paired with each test mode.
    mac : ndarray, shape (n,)
        MAC of each pair.
    macs : ndarray, shape (m, n)
        The full MAC matrix.
    """
    from scipy.optimize import linear_sum_assignment

    from sdctrl.updating.costs import mac as _mac

    macs = _mac(cphi_fe, cphi_id)
    rows, cols = linear_sum_assignment(-macs)
    index = np.empty(macs.shape[1], int)
    index[cols] = rows
    return index, macs[index, np.arange(macs.shape[1])], macs


def _fe_modes_upto(fe, fmax: float, nmin: int):
    """FE modes (Hz, shapes) up to ``fmax`` Hz, at least ``nmin`` of them."""
    n = min(fe.N, max(nmin, 20))
    while True:
        f, phi = fe.modes(n)
        if f[-1] >= fmax or n >= fe.N:
            break
        n = min(fe.N, 2 * n)
    keep = max(nmin, int(np.searchsorted(f, fmax, side="right")))
    return f[:keep], phi[:, :keep]


# ----------------------------------------------------------------------------------------
# the hybrid model
# ----------------------------------------------------------------------------------------
def hybrid(fe, nm, sensor_c, actuator_b=None, *, fmax: float | None = None,
           static_b=None, mac_min: float = MAC_POOR) -> HybridModel:
    """Hybrid experimental/analytical normal-mode model, eq. (5.1).

    Built from an identified normal-mode model ``nm`` (the measured modes of the test
    band) and an FE model ``fe``:

    - measured modes: the identified ``Omega`` (frequencies) and ``Gamma`` (full damping
      matrix, non-proportional terms kept), shapes expanded onto all FE DOFs by (4.7),
      ``phi_Ex = phi_FE A``, ``A = (c phi_FE)^+ (c phi)_ID``, where ``phi_FE`` are the FE
      modes paired with the test modes (maximal MAC, reported in ``info``);
    - every other FE mode up to ``fmax`` (below and above the test band, and FE modes of
      the band that no test mode paired with): analytic frequency and shape, damping ratio
      the mean of the measured ones, no damping coupling (section 5.1.1);
    - optionally static correction modes (2.21) of the FE model for ``static_b``,
      critically damped (``2 omega``, 2.20).

    Because the expansion basis and the appended modes are distinct FE modes, the appended
    shapes are mass- and stiffness-orthogonal (for the FE matrices) to the expanded ones.
    The outputs are ``y = c_c phi_c p`` with ``c_c = sensor_c`` (5.1): the expanded
    observabilities, which smooth the measured ones when there are more sensors than
    modes.

    Parameters
    ----------
    fe : FEModel
        The analytical model (need not be accurate: its shapes span the expansion).
    nm : NormalModeModel
        Identified normal modes (diagonal ``Omega``, rad/s^2; ``Gamma`` rad/s; ``cphi`` at
        the test sensors).  Its static term ``E`` is not used: the appended FE modes stand
        for the modes outside the band.
    sensor_c : array_like, shape (ns, N), or sequence of ns DOF labels
        The test sensors placed on the FE DOFs (rows match ``nm.sensors``).
    actuator_b : array_like, shape (N, na), or sequence of na DOF labels, optional
        FE input shapes of the model's inputs; then ``phib = phi_c^T actuator_b``.  By
        default the identified ``nm.phib`` is used for the measured modes and, when
        ``nm.actuators`` are FE DOF labels, point forces for the appended modes.
    fmax : float, optional
        Highest frequency (Hz) of the appended FE modes; default five times the highest
        measured frequency.
    static_b : array_like, shape (N, k), optional
        Input shapes (e.g. a strut, :meth:`FEModel.strut`) for which FE static correction
        modes are appended.  The thesis (5.1.2) warns that FE static corrections do not
        match expanded shapes well; use them with care.
    mac_min : float
        Pairs with a MAC below this value are reported with a warning.

    Returns
    -------
    HybridModel
        Modes sorted by frequency; ``shapes`` (also ``expanded``) on ``fe.dofs``;
        ``info`` holds ``"kind"`` (``"measured"``, ``"fe"``, ``"static"`` per mode),
        ``"measured"`` (bool mask), ``"pairing"`` (``test_mode``, ``fe_mode``, ``mac``,
        ``test_hz``, ``fe_hz`` arrays), ``"mac"`` (full FE x test MAC matrix),
        ``"poor_pairs"`` (test modes with MAC < ``mac_min``), ``"expansion"`` (``A``),
        ``"mean_damping"``.

    Raises
    ------
    TypeError
        ``fe`` is not an FEModel or ``nm`` not a NormalModeModel.
    ValueError
        Inconsistent shapes, unknown DOF labels, non-diagonal ``nm.Omega``, a
        non-positive ``fmax``.

    Warns
    -----
    UserWarning
        Poor FE/test pairing (MAC below ``mac_min``), fewer sensors than measured modes, or
        inputs that cannot be placed on the FE model.

    Examples
    --------
    >>> import sdctrl as sd
    >>> from sdctrl.testbeds import SENSORS, SHAKERS
    >>> fe = sd.testbed()
    >>> nm = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 18)
    >>> h = sd.hybrid(fe, nm, list(SENSORS))
    >>> bool(h.info["pairing"]["mac"].min() > 0.999)
    True
    """
    _check_fe(fe)
    _check_nm(nm)
    N = fe.N
    c, _ = _output_shapes(sensor_c, N, fe.dofs, "sensor_c")
    if c.shape[0] != nm.ns:
        raise ValueError(f"sensor_c must have one row per sensor of nm (ns={nm.ns}), got "
                         f"{c.shape[0]}")
    b = None
    if actuator_b is not None:
        b, _ = _input_shapes(actuator_b, N, fe.dofs, "actuator_b")
        if b.shape[1] != nm.na:
            raise ValueError(f"actuator_b must have one column per input of nm (na={nm.na}), "
                             f"got {b.shape[1]}")
    Om = nm.Omega
    if np.abs(Om - np.diag(np.diag(Om))).max() > 1e-8 * max(np.abs(Om).max(), 1e-300):
        raise ValueError("nm.Omega must be diagonal (normal modes): re-diagonalise with "
                         "nm.modified() first")
    w2_id = np.clip(np.diag(Om), 0, None)
    w_id = np.sqrt(w2_id)
    f_id = w_id / (2 * np.pi)
    n_id = nm.n
    if n_id == 0:
        raise ValueError("nm must hold at least one measured mode")
    if fmax is None:
        fmax = 5.0 * float(f_id.max())
    fmax = float(fmax)
    if not np.isfinite(fmax) or fmax <= 0:
        raise ValueError(f"fmax must be a positive frequency in Hz, got {fmax}")
    mac_min = float(mac_min)

    # FE modes, pairing, expansion basis
    f_fe, phi_fe = _fe_modes_upto(fe, max(fmax, 1.05 * float(f_id.max())), n_id)
    cphi_fe = c @ phi_fe
    fe_idx, mac_pairs, macs = pair_modes(cphi_fe, nm.cphi)
    if c.shape[0] < n_id:
        warnings.warn(f"hybrid: {c.shape[0]} sensors for {n_id} measured modes; the expansion "
                      "(4.7) needs more sensors than modes to be determined", stacklevel=2)
    shapes_ex, A = expand(phi_fe[:, fe_idx], c, nm.cphi)
    poor = np.flatnonzero(mac_pairs < mac_min)
    if poor.size:
        desc = ", ".join(f"test mode {j} ({f_id[j]:.2f} Hz) ~ FE mode {fe_idx[j]} "
                         f"({f_fe[fe_idx[j]]:.2f} Hz), MAC {mac_pairs[j]:.2f}" for j in poor)
        warnings.warn(f"hybrid: poor FE/test mode pairing (MAC < {mac_min:g}): {desc}",
                      stacklevel=2)

    # appended analytic modes
    app = np.setdiff1d(np.arange(f_fe.size), fe_idx)
    phi_app = phi_fe[:, app]
    w_app = 2 * np.pi * f_fe[app]
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.diag(nm.Gamma) / (2 * w_id)
    zeta = zeta[w_id > 0]
    zeta_mean = float(np.mean(zeta)) if zeta.size else 0.0
    blocks_shapes = [shapes_ex, phi_app]
    w2 = [w2_id, w_app**2]
    kinds = ["measured"] * n_id + ["fe"] * app.size
    gam = [np.asarray(nm.Gamma), np.diag(2 * zeta_mean * w_app)]

    if static_b is not None:
        from sdctrl.fe.static import principal_static_basis

        Bs, _ = _input_shapes(static_b, N, fe.dofs, "static_b")
        Ps = fe.static_correction(Bs, phi_fe)
        Ps = Ps - phi_fe @ (phi_fe.T @ np.asarray(fe.M @ Ps))
        V, wc2 = principal_static_basis(Ps, fe.M, fe.K)
        if V.shape[1]:
            wc2 = np.clip(wc2, 0, None)
            blocks_shapes.append(V)
            w2.append(wc2)
            kinds += ["static"] * V.shape[1]
            gam.append(np.diag(2 * np.sqrt(wc2)))

    shapes = np.hstack(blocks_shapes)
    w2 = np.concatenate(w2)
    n = shapes.shape[1]
    Gamma = np.zeros((n, n))
    i0 = 0
    for G in gam:
        k = G.shape[0]
        Gamma[i0:i0 + k, i0:i0 + k] = G
        i0 += k
    order = np.argsort(w2, kind="stable")
    shapes, w2, Gamma = shapes[:, order], w2[order], Gamma[np.ix_(order, order)]
    kinds = np.asarray(kinds)[order]
    measured = kinds == "measured"

    cphi = c @ shapes
    if b is not None:
        phib = shapes.T @ b
    else:
        phib = np.zeros((n, nm.na))
        phib[measured] = nm.phib
        if nm.na and set(nm.actuators) <= set(fe.dofs):
            phib[~measured] = shapes[:, ~measured].T @ fe.point(list(nm.actuators))
        elif nm.na and np.any(~measured):
            warnings.warn("hybrid: nm.actuators are not FE DOF labels, so the appended FE "
                          "modes are not excited by the model's inputs; give actuator_b",
                          stacklevel=2)

    pairing = {"test_mode": np.arange(n_id), "fe_mode": fe_idx, "mac": mac_pairs,
               "test_hz": f_id, "fe_hz": f_fe[fe_idx]}
    info = {"source": "hybrid", "kind": kinds, "measured": measured, "pairing": pairing,
            "mac": macs, "poor_pairs": poor, "expansion": A, "mean_damping": zeta_mean,
            "fe_frequency_hz": f_fe, "n_static": int(np.sum(kinds == "static")),
            "dropped_E": nm.E is not None and bool(np.any(nm.E))}
    return HybridModel(np.diag(w2), 0.5 * (Gamma + Gamma.T), cphi, phib, sensors=nm.sensors,
                       actuators=nm.actuators, shapes=shapes, dofs=fe.dofs, info=info)


def pairing_report(model) -> str:
    """Markdown table of the FE/test mode pairing of a hybrid model (from its ``info``).

    Parameters
    ----------
    model : HybridModel
        A model returned by :func:`hybrid`.

    Returns
    -------
    str
        One row per measured mode: test and FE frequencies (Hz), their ratio and the MAC,
        poor pairs flagged.
    """
    p = model.info.get("pairing") if hasattr(model, "info") else None
    if p is None:
        raise ValueError("model has no pairing information (not built by hybrid)")
    poor = set(np.asarray(model.info.get("poor_pairs", ())).tolist())
    rows = ["| test mode | test Hz | FE mode | FE Hz | FE/test | MAC |",
            "|---:|---:|---:|---:|---:|---:|"]
    for j in range(p["test_mode"].size):
        flag = " (poor)" if j in poor else ""
        rows.append(f"| {j} | {p['test_hz'][j]:.3f} | {p['fe_mode'][j]} | {p['fe_hz'][j]:.3f} "
                    f"| {p['fe_hz'][j] / p['test_hz'][j]:.4f} | {p['mac'][j]:.3f}{flag} |")
    return "\n".join(rows)


# ----------------------------------------------------------------------------------------
# predictions
# ----------------------------------------------------------------------------------------
def _as_hybrid(model) -> HybridModel:
    if isinstance(model, HybridModel):
        return model
    return HybridModel(**{f.name: getattr(model, f.name) for f in fields(model) if f.init})


def _static_terms_dropped(model) -> dict:
    """``E`` (and the residual mass ``F`` when the model has one) belong to the old I/O."""
    return {f.name: None for f in fields(model) if f.name in ("E", "F")}


def with_io(model, b=None, c=None, *, actuators=None, sensors=None) -> HybridModel:
    """Model with new inputs and/or outputs on the DOFs of its shapes (untested loops, 5.1).

    ``phib = phi_c^T b`` and ``cphi = c phi_c``: the response of shakers and sensors that
    were not part of the test, predicted from the expanded shapes.

    Parameters
    ----------
    model : NormalModeModel
        A model with ``shapes`` (hybrid or FE-derived).
    b : array_like, shape (N, k), or DOF label(s), optional
        Input shapes on the DOFs of ``model.shapes``; None keeps the model's inputs.
    c : array_like, shape (k, N), or DOF label(s), optional
        Output shapes (displacement); None keeps the model's outputs.
    actuators : sequence of str, optional
        Labels of the new inputs (default: the DOF labels when ``b`` is given as labels,
        else ``a0, a1, ...``).
    sensors : sequence of str, optional
        Labels of the new outputs (default: DOF labels or ``s0, s1, ...``).

    Returns
    -------
    HybridModel
        Same modes; the static terms ``E`` (and ``F``) are dropped when the inputs or
        outputs change (they belong to the old ones).

    Raises
    ------
    ValueError
        The model has no shapes, wrong shapes, unknown labels.

    Examples
    --------
    >>> import sdctrl as sd
    >>> fe = sd.testbed()
    >>> nm = fe.normal_mode_model(["N30.z"], ["N30.z"], 18)
    >>> m2 = with_io(nm, b=["N41.y"], c=["N41.y", "N30.z"])
    >>> m2.actuators, m2.sensors
    (('N41.y',), ('N41.y', 'N30.z'))
    """
    _check_nm(model, "model")
    if model.shapes is None:
        raise ValueError("model has no shapes on physical DOFs: with_io needs a hybrid or "
                         "FE-derived model")
    N = model.shapes.shape[0]
    changes = {}
    if b is not None:
        B, labels = _input_shapes(b, N, model.dofs, "b")
        changes["phib"] = model.shapes.T @ B
        changes["actuators"] = actuators if actuators is not None else labels
        changes.update(_static_terms_dropped(model))
    elif actuators is not None:
        changes["actuators"] = actuators
    if c is not None:
        Cm, labels = _output_shapes(c, N, model.dofs, "c")
        changes["cphi"] = Cm @ model.shapes
        changes["sensors"] = sensors if sensors is not None else labels
        changes.update(_static_terms_dropped(model))
    elif sensors is not None:
        changes["sensors"] = sensors
    return _as_hybrid(model).replace(**changes)


def _reduce(X, shapes: np.ndarray, name: str) -> np.ndarray | None:
    if X is None:
        return None
    N = shapes.shape[0]
    if sp.issparse(X):
        if X.shape != (N, N):
            raise ValueError(f"{name} must have shape ({N}, {N}), got {X.shape}")
        data = X.tocsr().data
        if data.size and not np.all(np.isfinite(data)):
            raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
        R = shapes.T @ np.asarray(X @ shapes)
    else:
        Xa = as_array(X, name, shape=(N, N))
        R = shapes.T @ Xa @ shapes
    return 0.5 * (R + R.T)


def modify(model, dM=None, dC=None, dK=None) -> HybridModel:
    """Prediction of a modification given on physical DOFs by reanalysis, eq. (5.2).

    ``(I + dmu) p'' + (Gamma_c + dGamma) p' + (Omega_c + dOmega) p = phi_c^T b_c u`` with
    ``dmu = phi_c^T dM phi_c``, ``dGamma = phi_c^T dC phi_c``, ``dOmega = phi_c^T dK phi_c``,
    re-expressed on its normal modes (:meth:`NormalModeModel.modified`, 4.17).

    Parameters
    ----------
    model : NormalModeModel
        A model with ``shapes`` (hybrid or FE-derived).
    dM : array_like or sparse, shape (N, N), optional
        Mass modification on the DOFs of ``model.shapes``.
    dC : array_like or sparse, shape (N, N), optional
        Damping modification.
    dK : array_like or sparse, shape (N, N), optional
        Stiffness modification.

    Returns
    -------
    HybridModel
        ``info["transformation"]`` maps the new modal coordinates to the old ones.

    Raises
    ------
    ValueError
        No shapes, wrong shapes, non-finite values, or ``I + dmu`` not positive definite.
    """
    _check_nm(model, "model")
    if model.shapes is None:
        raise ValueError("model has no shapes on physical DOFs: modify needs a hybrid or "
                         "FE-derived model (or use model.modified with modal changes)")
    S = model.shapes
    return _as_hybrid(model).modified(dmu=_reduce(dM, S, "dM"), dGamma=_reduce(dC, S, "dC"),
                                      dOmega=_reduce(dK, S, "dK"))


def strut_feedback(model, fe, node_a: str, node_b: str, kp=0.0, kv=0.0) -> HybridModel:
    """Closed loop of a D-strut on the bar ``node_a``-``node_b``, eqs. (5.3)-(5.4).

    The strut measures the relative axial extension ``y = c_s q`` and applies the relative
    force ``F = -kv y' - kp y`` through ``b_s = c_s^T`` (:meth:`FEModel.strut`), i.e. adds
    ``kv b_s b_s^T`` to the damping and ``kp b_s b_s^T`` to the stiffness.

    Parameters
    ----------
    model : NormalModeModel
        Hybrid or FE-derived model whose ``shapes`` are on ``fe.dofs``.
    fe : FEModel
        Gives the node coordinates and DOF numbering of the strut.
    node_a, node_b : str
        End nodes of the bar.
    kp : float
        Position gain (N/m): an added (negative: removed) axial stiffness.
    kv : float
        Velocity gain (N s/m): the strut's dashpot.

    Returns
    -------
    HybridModel
        Same inputs and outputs as ``model``.
    """
    _check_nm(model, "model")
    _check_fe(fe)
    if model.shapes is None or model.shapes.shape[0] != fe.N:
        raise ValueError("model must have shapes on the DOFs of fe (shape (N, n) with "
                         f"N={fe.N})")
    s = fe.strut(node_a, node_b)
    return _as_hybrid(model).with_feedback(s, s.T, kp=kp, kv=kv)


