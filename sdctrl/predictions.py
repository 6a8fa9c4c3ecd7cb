"""Predictions with models whose shapes live on FE DOFs (thesis 5.1.3, eqs. 5.2-5.4).

A hybrid model (5.1, built by :func:`sdctrl.hybrid`) or an FE-derived normal-mode model
carries its shapes ``phi_c`` on the DOFs of an FE model, so it predicts the response of
inputs and outputs that were not part of the test (:func:`with_io`), of modifications
``dM, dC, dK`` given on those DOFs by reanalysis (5.2, :func:`modify`) and of D-strut loops
(5.3)-(5.4) (:func:`strut_feedback`).  :class:`HybridModel` is the normal-mode model with
these doors; :func:`pairing_report` tabulates the FE/test mode pairing of its construction.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from sdctrl.fe.validation import check_fe_model, shapes_on_dofs
from sdctrl.modal import NormalModeModel
from sdctrl.updating.reanalysis import reanalysis

__all__ = ["HybridModel", "modify", "pairing_report", "strut_feedback", "with_io"]


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
        B, labels = shapes_on_dofs(b, N, model.dofs, "b")
        changes["phib"] = model.shapes.T @ B
        changes["actuators"] = actuators if actuators is not None else labels
        changes.update(_static_terms_dropped(model))
    elif actuators is not None:
        changes["actuators"] = actuators
    if c is not None:
        Cm, labels = shapes_on_dofs(c, N, model.dofs, "c", output=True)
        changes["cphi"] = Cm @ model.shapes
        changes["sensors"] = sensors if sensors is not None else labels
        changes.update(_static_terms_dropped(model))
    elif sensors is not None:
        changes["sensors"] = sensors
    return _as_hybrid(model).replace(**changes)


def modify(model, dM=None, dC=None, dK=None) -> HybridModel:
    """Prediction of a modification given on physical DOFs by reanalysis, eq. (5.2).

    ``(I + dmu) p'' + (Gamma_c + dGamma) p' + (Omega_c + dOmega) p = phi_c^T b_c u`` with
    ``dmu = phi_c^T dM phi_c``, ``dGamma = phi_c^T dC phi_c``, ``dOmega = phi_c^T dK phi_c``,
    re-expressed on its normal modes: the reanalysis (4.17) of
    :func:`sdctrl.updating.reanalysis.reanalysis` on the hybrid basis.

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
    return reanalysis(_as_hybrid(model), dM, dC, dK)


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
    check_fe_model(fe, "fe")
    if model.shapes is None or model.shapes.shape[0] != fe.N:
        raise ValueError("model must have shapes on the DOFs of fe (shape (N, n) with "
                         f"N={fe.N})")
    s = fe.strut(node_a, node_b)
    return _as_hybrid(model).with_feedback(s, s.T, kp=kp, kv=kv)


def pairing_report(model) -> str:
    """Markdown table of the FE/test mode pairing of a hybrid model (from its ``info``).

    Parameters
    ----------
    model : HybridModel
        A model returned by :func:`sdctrl.hybrid`.

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
