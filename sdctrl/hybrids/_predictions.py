"""Predictions with models whose shapes live on FE DOFs (thesis 5.1.3, eqs. 5.2-5.4).

A hybrid model (5.1, built by :func:`sdctrl.hybrid`) or an FE-derived normal-mode model
carries its shapes ``phi_c`` on the DOFs of an FE model, so it predicts the response of
inputs and outputs that were not part of the test (:func:`with_io`), of modifications
``dM, dC, dK`` given on those DOFs by reanalysis (5.2, :func:`with_modification`) and of
D-strut loops (5.3)-(5.4) (:meth:`HybridModel.with_feedback` with ``b = fe.strut(a, b)``).
:class:`HybridModel` is the normal-mode model with these doors; :func:`pairing_report`
tabulates the FE/test mode pairing of its construction.

Static correction of the predictions (beyond the thesis).  A truncated modal basis cannot
hold the local static response to a large change (a strut as soft as the bar it replaces,
a broken strut): the thesis adds the FE static correction mode (4.23), and finds it fails
with expanded shapes (5.1.2, Table 5.2) because it was built against the FE modes.  A model
that carries its FE model (``fe``, set by :func:`sdctrl.hybrid`) and its physical test
sensors and inputs (``sensor_c``, ``actuator_b``) appends, for every new load shape, the
correction made consistent with its own shapes
(:func:`sdctrl.fe._static.consistent_static_modes`: the FE static response ``K^-1 b``
made mass-orthogonal to the shapes, with its projected stiffness and the FE's projected
damping, critical (2.20) when the FE model has none): :func:`with_static`.
:meth:`HybridModel.with_feedback`, :func:`with_io` (new inputs) and :func:`with_modification` do it
by default (``static=None``); ``static=False`` gives the plain projection of the thesis.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from sdctrl._lib.validate import as_array, readonly
from sdctrl.fe._static import (consistent_static_modes, static_mode_damping,
                               with_static_blocks)
from sdctrl.fe._fe_checks import shapes_on_dofs
from sdctrl.fe._fe_model import check_fe_model
from sdctrl.hybrids._hybrid_records import KINDS, HybridConstruction, pairing_report
from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.updating._reanalysis import modification_loads, reanalysis

__all__ = ["HybridModel", "pairing_report", "with_io", "with_modification", "with_static"]


@dataclass(frozen=True, eq=False, repr=False)      # the concise repr of NormalModeModel
class HybridModel(NormalModeModel):
    """Normal-mode model whose shapes live on FE DOFs (hybrid model 5.1).

    A :class:`~sdctrl.NormalModeModel` (same fields and methods) with the doors that need
    shapes on the DOFs of an FE model: :meth:`with_io` (untested inputs and outputs) and
    :meth:`with_modification` (``dM, dC, dK`` on FE DOFs, 5.2; :meth:`modified` takes
    changes in modal coordinates).  :meth:`replace` keeps the
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
    omega_c, F, properness, transformation, n_static, residual, omega_f
        As for :class:`~sdctrl.NormalModeModel` (``n_static``: the modes of kind ``"static"``;
        ``residual``: the identified residual dynamics kept at the tested I/O with
        ``residual="tested"`` (:func:`sdctrl.hybrid`), else None).
    std : dict, optional
        One standard deviation of each entry of ``Omega``, ``Gamma``, ``cphi``, ``phib``.
    fe : FEModel, optional
        The FE model the shapes live on (set by :func:`sdctrl.hybrid`); with ``sensor_c``
        and ``actuator_b`` it enables the static correction of predictions.
    sensor_c : array_like, shape (ns, N), optional
        Physical output shapes of the model's sensors on the DOFs of ``shapes``.
    actuator_b : array_like, shape (N, na), optional
        Physical input shapes of the model's actuators.
    kind : sequence of str, shape (n,), optional
        Origin of each mode: ``"measured"``, ``"fe"`` (appended FE mode), ``"residual"``
        (static correction of the test inputs), ``"static"`` (static correction of extra
        loads); :attr:`measured` is ``kind == "measured"``.
    construction : HybridConstruction, optional
        What :func:`sdctrl.hybrid` found: pairing, absorbed poles, expansion, residual terms.
    """

    fe: object = None
    sensor_c: np.ndarray | None = None
    actuator_b: np.ndarray | None = None
    kind: np.ndarray | None = None
    construction: HybridConstruction | None = None

    def __post_init__(self):
        super().__post_init__()
        N = None if self.shapes is None else self.shapes.shape[0]
        if self.fe is not None:
            check_fe_model(self.fe, "fe")
            if N != self.fe.N:
                raise ValueError(f"fe has N={self.fe.N} DOFs but shapes has "
                                 f"{'none' if N is None else N} rows")
        for name, val, shape in (("sensor_c", self.sensor_c, (self.ns, N)),
                                 ("actuator_b", self.actuator_b, (N, self.na))):
            if val is None:
                continue
            if N is None:
                raise ValueError(f"{name} given without shapes")
            object.__setattr__(self, name, readonly(as_array(val, name, shape=shape)))
        if self.kind is not None:
            kind = np.array(self.kind, dtype=str)
            if kind.shape != (self.n,) or not set(kind.tolist()) <= set(KINDS):
                raise ValueError(f"kind must hold one of {KINDS} per mode (n={self.n})")
            object.__setattr__(self, "kind", readonly(kind))

    @property
    def measured(self) -> np.ndarray | None:
        """Mask of the measured modes (``kind == "measured"``), None without ``kind``."""
        return None if self.kind is None else self.kind == "measured"

    @property
    def static_ready(self) -> bool:
        """True when the model can append static correction modes (:func:`with_static`)."""
        return (self.fe is not None and self.sensor_c is not None
                and self.actuator_b is not None)

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
            ``sensor_c`` (``actuator_b``) is dropped when new ``cphi`` (``phib``) changes the
            number of outputs (inputs) without giving it: the physical shapes of the new
            signals are unknown (no static correction then); so is ``kind`` when a new
            ``Omega`` changes the number of modes without giving it.
        """
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        kw["std"] = None if changes.keys() & {"Omega", "Gamma", "cphi", "phib"} else self.std
        kw.update(changes)
        for name, key, axis in (("sensor_c", "cphi", 0), ("actuator_b", "phib", 1),
                                ("kind", "Omega", 0)):
            old, new = kw[name], changes.get(key)
            if (name not in changes and old is not None and new is not None
                    and np.ndim(new) == 2 and np.shape(new)[axis] != old.shape[axis]):
                kw[name] = None
        return type(self)(**kw)

    def _repr_markdown_(self) -> str:
        md = super()._repr_markdown_()
        if self.construction is None or self.construction.pairing is None:
            return md
        return md + "\n\n**FE/test mode pairing**\n\n" + pairing_report(self)

    def with_io(self, b=None, c=None, *, actuators=None, sensors=None,
                static: bool | None = None) -> HybridModel:
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
        static : bool, optional
            Append static correction modes for the new inputs (default: when the model
            carries its FE model, :attr:`static_ready`).

        Returns
        -------
        HybridModel
        """
        return with_io(self, b, c, actuators=actuators, sensors=sensors, static=static)

    def with_static(self, loads) -> HybridModel:
        """Model with static correction modes for ``loads``; see :func:`with_static`.

        Parameters
        ----------
        loads : array_like, shape (N, k), or DOF label(s)
            Load shapes on the DOFs of :attr:`shapes`.

        Returns
        -------
        HybridModel
        """
        return with_static(self, loads)

    def with_feedback(self, b, c, kp=0.0, kv=0.0, modal: bool = False,
                      static: bool | None = None) -> HybridModel:
        """Closed loop with relative force feedback ``F = -kv y' - kp y`` (5.3)-(5.4).

        As :meth:`NormalModeModel.with_feedback`, after appending static correction modes
        consistent with the shapes for the force shapes ``b`` (:func:`with_static`):
        without them a truncated basis misses the local static response of a stiffness
        change (thesis 5.1.2, Table 5.2) and the relaxation of a dashpot through the local
        flexibility.

        Parameters
        ----------
        b : array_like, shape (N, k) or (n, k)
            Force input shapes on the DOFs of :attr:`shapes`, or ``phi^T b`` if ``modal``.
        c : array_like, shape (k, N) or (k, n)
            Measured relative displacements on the DOFs of :attr:`shapes`, or ``c phi``.
        kp : float or array_like, shape (k,) or (k, k)
            Position (stiffness) gain, force per unit displacement.
        kv : float or array_like, shape (k,) or (k, k)
            Velocity (damping) gain, force per unit velocity.
        modal : bool
            True when ``b`` and ``c`` are already modal (then no static correction).
        static : bool, optional
            Append the static correction of ``b`` first; default: when the model carries
            its FE model (:attr:`static_ready`) and ``modal`` is False.  ``False`` gives
            the plain projection (5.4).

        Returns
        -------
        HybridModel
        """
        model = self
        if not modal and _static_default(self, static):
            bb = as_array(b, "b", ndim=(1, 2))
            model = with_static(self, bb.reshape(-1, 1) if bb.ndim == 1 else bb)
        return NormalModeModel.with_feedback(model, b, c, kp, kv, modal)

    def with_modification(self, dM=None, dC=None, dK=None, *,
                          static: bool | None = None) -> HybridModel:
        """Prediction after ``dM, dC, dK`` on the FE DOFs (5.2); see :func:`with_modification`.

        The physical-DOF counterpart of :meth:`modified` (changes in modal coordinates).

        Parameters
        ----------
        dM : array_like or sparse, shape (N, N), optional
            Mass modification on the DOFs of :attr:`shapes`.
        dC : array_like or sparse, shape (N, N), optional
            Damping modification.
        dK : array_like or sparse, shape (N, N), optional
            Stiffness modification.
        static : bool, optional
            Append static correction modes for the loads of the modification first
            (default: when the model carries its FE model).

        Returns
        -------
        HybridModel
        """
        return with_modification(self, dM, dC, dK, static=static)


def _check_nm(nm, name: str = "nm"):
    if not isinstance(nm, NormalModeModel):
        raise TypeError(f"{name} must be a NormalModeModel, got {type(nm).__name__}")


def _as_hybrid(model) -> HybridModel:
    if isinstance(model, HybridModel):
        return model
    return HybridModel(**{f.name: getattr(model, f.name) for f in fields(model) if f.init})


def _static_terms_dropped(model) -> dict:
    """``E`` (and the residual mass ``F`` when the model has one) belong to the old I/O."""
    return {f.name: None for f in fields(model) if f.name in ("E", "F")}


def _static_default(model, static) -> bool:
    """Resolve the ``static`` switch: None means on when the model can do it."""
    ready = isinstance(model, HybridModel) and model.static_ready
    if static is None:
        return ready
    if not isinstance(static, bool | np.bool_):
        raise TypeError(f"static must be True, False or None, got {static!r}")
    if static and not ready:
        raise ValueError("static=True needs a model that carries its FE model, sensor_c and "
                         "actuator_b (a model built by sdctrl.hybrid)")
    return bool(static)


def with_static(model, loads, *, response=None) -> HybridModel:
    """Model with static correction modes for ``loads``, consistent with its shapes.

    The FE static response ``K^-1 loads`` (4.23) made mass-orthogonal to the model's
    shapes and orthonormalised (4.24) (:func:`sdctrl.fe._static.consistent_static_modes`),
    appended as modes with their projected stiffness and the FE model's damping projected
    on them, ``V^T C V`` (critical damping ``2 omega``, 2.20, when the FE model has no
    ``C``: a critically damped static mode in a strut's loop adds a damping path the
    structure does not have, :func:`sdctrl.fe._static.with_static_blocks`), uncoupled
    from the other modes (2.22).  The model then represents the part of
    the static response to the loads that its shapes miss: the local flexibility a large
    stiffness change (a soft or broken strut) excites, or the residual flexibility of a new
    input.  Directions the shapes already hold add nothing.

    Parameters
    ----------
    model : HybridModel
        A model that carries its FE model, ``sensor_c`` and ``actuator_b``
        (:attr:`HybridModel.static_ready`, e.g. built by :func:`sdctrl.hybrid`).
    loads : array_like, shape (N, k), or DOF label(s)
        Load shapes on the DOFs of the model's shapes.
    response : ndarray, shape (N, k), optional
        Their static response ``K^-1 loads`` when the caller has it already (the folds of
        ``sdctrl.hybrid(residual="auto")`` share one solve); computed otherwise.

    Returns
    -------
    HybridModel
        ``k' <= k`` more modes (appended last, ``kind`` extended with ``"static"`` when
        present, ``n_static`` increased); same inputs, outputs and ``E``.

    Raises
    ------
    ValueError
        A model without its FE model, or bad load shapes.
    """
    _check_nm(model, "model")
    if not (isinstance(model, HybridModel) and model.static_ready):
        raise ValueError("model must carry its FE model, sensor_c and actuator_b (a model "
                         "built by sdctrl.hybrid) to append static correction modes")
    L, _ = shapes_on_dofs(loads, model.shapes.shape[0], model.dofs, "loads")
    V, wc2 = consistent_static_modes(model.fe, L, model.shapes, response=response)
    k = V.shape[1]
    if k == 0:
        return model
    Omega, Gamma = with_static_blocks(model.Omega, model.Gamma, wc2,
                                      static_mode_damping(model.fe, V))
    kind = None if model.kind is None else np.concatenate([model.kind, np.full(k, "static")])
    return model.replace(kind=kind, n_static=model.n_static + k,
        Omega=Omega, Gamma=Gamma, shapes=np.hstack([model.shapes, V]),
        cphi=np.hstack([model.cphi, model.sensor_c @ V]),
        phib=np.vstack([model.phib, V.T @ model.actuator_b]))


def with_io(model, b=None, c=None, *, actuators=None, sensors=None,
            static: bool | None = None) -> HybridModel:
    """Model with new inputs and/or outputs on the DOFs of its shapes (untested loops, 5.1).

    ``phib = phi_c^T b`` and ``cphi = c phi_c``: the response of shakers and sensors that
    were not part of the test, predicted from the expanded shapes.  For a model that
    carries its FE model, the static correction of the new inputs (their residual
    flexibility, 2.21, made consistent with the shapes) is appended first
    (:func:`with_static`).

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
    static : bool, optional
        Append static correction modes for the new inputs; default: when the model
        carries its FE model (:attr:`HybridModel.static_ready`).

    Returns
    -------
    HybridModel
        Same modes (plus the static corrections); the static terms ``E`` (and ``F``) are
        dropped when the inputs or outputs change (they belong to the old ones).

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
    model = _as_hybrid(model)
    N = model.shapes.shape[0]
    B = Cm = None
    if b is not None:
        B, alab = shapes_on_dofs(b, N, model.dofs, "b")
    if c is not None:
        Cm, slab = shapes_on_dofs(c, N, model.dofs, "c", output=True)
    if B is not None and _static_default(model, static):
        model = with_static(model, B)
    changes = {}
    if B is not None:
        changes.update(phib=model.shapes.T @ B, actuator_b=B,
                       actuators=actuators if actuators is not None else alab)
        changes.update(_static_terms_dropped(model))
        if Cm is None and model.sensor_c is not None:
            # the residual flexibility of the old inputs, carried by the correction modes'
            # observabilities (sdctrl.hybrid), belongs to them: back to the physical shapes
            changes["cphi"] = model.sensor_c @ model.shapes
    elif actuators is not None:
        changes["actuators"] = actuators
    if Cm is not None:
        changes.update(cphi=Cm @ model.shapes, sensor_c=Cm,
                       sensors=sensors if sensors is not None else slab)
        changes.update(_static_terms_dropped(model))
    elif sensors is not None:
        changes["sensors"] = sensors
    return model.replace(**changes)


def with_modification(model, dM=None, dC=None, dK=None, *,
                      static: bool | None = None) -> HybridModel:
    """Prediction of a modification given on physical DOFs by reanalysis, eq. (5.2).

    ``(I + dmu) p'' + (Gamma_c + dGamma) p' + (Omega_c + dOmega) p = phi_c^T b_c u`` with
    ``dmu = phi_c^T dM phi_c``, ``dGamma = phi_c^T dC phi_c``, ``dOmega = phi_c^T dK phi_c``,
    re-expressed on its normal modes: the reanalysis (4.17) of
    :func:`sdctrl.updating._reanalysis.reanalysis` on the hybrid basis.  For a model that
    carries its FE model, static correction modes (4.22)-(4.24) for the loads of the
    modification (:func:`~sdctrl.updating._reanalysis.modification_loads`), consistent with the
    shapes, are appended to the basis first (:func:`with_static`).

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
    static : bool, optional
        Append the static correction of the modification's loads; default: when the
        model carries its FE model (:attr:`HybridModel.static_ready`).

    Returns
    -------
    HybridModel
        ``transformation`` maps the new modal coordinates to the old ones.

    Raises
    ------
    ValueError
        No shapes, wrong shapes, non-finite values, or ``I + dmu`` not positive definite.
    """
    _check_nm(model, "model")
    if model.shapes is None:
        raise ValueError("model has no shapes on physical DOFs: with_modification needs a "
                         "hybrid or FE-derived model (or use model.modified with modal "
                         "changes)")
    model = _as_hybrid(model)
    if _static_default(model, static):
        loads = modification_loads(dM, dC, dK, model.shapes.shape[0])
        if loads.shape[1]:
            model = with_static(model, loads)
    return reanalysis(model, dM, dC, dK)


