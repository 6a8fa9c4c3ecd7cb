"""Hybrid experimental/analytical models: construction (thesis 5.1.1, eq. 5.1).

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
shapes live on FE DOFs, the hybrid predicts untested sensors/actuators, modifications
``dM, dC, dK`` given on FE DOFs (5.2) and D-strut loops (5.3)-(5.4): the
:class:`~sdctrl.predictions.HybridModel` class and its predictions are in
:mod:`sdctrl.predictions`, the expansion and pairing in :mod:`sdctrl.updating.expansion`;
this module builds the model (5.1.1).
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl.fe.validation import check_fe_model, shapes_on_dofs
from sdctrl.modal import NormalModeModel
from sdctrl.predictions import HybridModel, pairing_report
from sdctrl.updating.expansion import MAC_POOR, expand, pair_modes

__all__ = ["hybrid", "pairing_report"]


# ----------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------
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
    check_fe_model(fe, "fe")
    if not isinstance(nm, NormalModeModel):
        raise TypeError(f"nm must be a NormalModeModel, got {type(nm).__name__}")
    c, b = _test_io(fe, nm, sensor_c, actuator_b)
    w2_id, fmax, mac_min = _measured(nm, fmax, mac_min)
    f_id = np.sqrt(w2_id) / (2 * np.pi)
    # FE modes, pairing, expansion basis (4.7)
    f_fe, phi_fe = _fe_modes_upto(fe, max(fmax, 1.05 * float(f_id.max())), nm.n)
    fe_idx, mac_pairs, macs = pair_modes(c @ phi_fe, nm.cphi)
    if c.shape[0] < nm.n:
        warnings.warn(f"hybrid: {c.shape[0]} sensors for {nm.n} measured modes; the expansion "
                      "(4.7) needs more sensors than modes to be determined", stacklevel=2)
    shapes_ex, A = expand(phi_fe[:, fe_idx], c, nm.cphi)
    poor = np.flatnonzero(mac_pairs < mac_min)
    if poor.size:
        desc = ", ".join(f"test mode {j} ({f_id[j]:.2f} Hz) ~ FE mode {fe_idx[j]} "
                         f"({f_fe[fe_idx[j]]:.2f} Hz), MAC {mac_pairs[j]:.2f}" for j in poor)
        warnings.warn(f"hybrid: poor FE/test mode pairing (MAC < {mac_min:g}): {desc}",
                      stacklevel=2)
    # measured, appended analytic FE and static correction modes (5.1)
    zeta_mean = _mean_damping(nm, np.sqrt(w2_id))
    app = np.setdiff1d(np.arange(f_fe.size), fe_idx)
    w_app = 2 * np.pi * f_fe[app]
    blocks = [(shapes_ex, w2_id, np.asarray(nm.Gamma), "measured"),
              (phi_fe[:, app], w_app**2, np.diag(2 * zeta_mean * w_app), "fe")]
    if static_b is not None:
        blocks.append(_static_block(fe, static_b, phi_fe))
    shapes, w2, Gamma, kinds = _stack_blocks(blocks)
    measured = kinds == "measured"
    phib, unexcited = _inputs(fe, nm, shapes, measured, b)
    if unexcited:
        warnings.warn("hybrid: nm.actuators are not FE DOF labels, so the appended FE "
                      "modes are not excited by the model's inputs; give actuator_b",
                      stacklevel=2)
    pairing = {"test_mode": np.arange(nm.n), "fe_mode": fe_idx, "mac": mac_pairs,
               "test_hz": f_id, "fe_hz": f_fe[fe_idx]}
    info = {"source": "hybrid", "kind": kinds, "measured": measured, "pairing": pairing,
            "mac": macs, "poor_pairs": poor, "expansion": A, "mean_damping": zeta_mean,
            "fe_frequency_hz": f_fe, "n_static": int(np.sum(kinds == "static")),
            "dropped_E": nm.E is not None and bool(np.any(nm.E))}
    return HybridModel(np.diag(w2), 0.5 * (Gamma + Gamma.T), c @ shapes, phib,
                       sensors=nm.sensors, actuators=nm.actuators, shapes=shapes, dofs=fe.dofs,
                       info=info)


def _test_io(fe, nm, sensor_c, actuator_b):
    """Test sensors ``c`` (ns, N) and, when given, actuators ``b`` (N, na) on the FE DOFs."""
    N = fe.N
    c, _ = shapes_on_dofs(sensor_c, N, fe.dofs, "sensor_c", output=True)
    if c.shape[0] != nm.ns:
        raise ValueError(f"sensor_c must have one row per sensor of nm (ns={nm.ns}), got "
                         f"{c.shape[0]}")
    b = None
    if actuator_b is not None:
        b, _ = shapes_on_dofs(actuator_b, N, fe.dofs, "actuator_b")
        if b.shape[1] != nm.na:
            raise ValueError(f"actuator_b must have one column per input of nm (na={nm.na}), "
                             f"got {b.shape[1]}")
    return c, b


def _measured(nm, fmax, mac_min):
    """Measured ``omega^2`` (rad/s)^2 of ``nm`` (normal modes), ``fmax`` Hz and ``mac_min``."""
    Om = nm.Omega
    if np.abs(Om - np.diag(np.diag(Om))).max() > 1e-8 * max(np.abs(Om).max(), 1e-300):
        raise ValueError("nm.Omega must be diagonal (normal modes): re-diagonalise with "
                         "nm.modified() first")
    w2_id = np.clip(np.diag(Om), 0, None)
    if nm.n == 0:
        raise ValueError("nm must hold at least one measured mode")
    if fmax is None:
        fmax = 5.0 * float((np.sqrt(w2_id) / (2 * np.pi)).max())
    fmax = float(fmax)
    if not np.isfinite(fmax) or fmax <= 0:
        raise ValueError(f"fmax must be a positive frequency in Hz, got {fmax}")
    return w2_id, fmax, float(mac_min)


def _mean_damping(nm, w_id) -> float:
    """Mean measured damping ratio, given to the appended FE modes (5.1.1)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.diag(nm.Gamma) / (2 * w_id)
    zeta = zeta[w_id > 0]
    return float(np.mean(zeta)) if zeta.size else 0.0


def _static_block(fe, static_b, phi_fe):
    """FE static correction modes (2.21), (4.24) for ``static_b``, critically damped."""
    from sdctrl.fe.static import principal_static_basis

    Bs, _ = shapes_on_dofs(static_b, fe.N, fe.dofs, "static_b")
    Ps = fe.static_correction(Bs, phi_fe)
    Ps = Ps - phi_fe @ (phi_fe.T @ np.asarray(fe.M @ Ps))
    V, wc2 = principal_static_basis(Ps, fe.M, fe.K)
    wc2 = np.clip(wc2, 0, None)
    return V, wc2, np.diag(2 * np.sqrt(wc2)), "static"


def _stack_blocks(blocks):
    """Shapes, ``omega^2``, block-diagonal ``Gamma`` and kinds, sorted by frequency."""
    shapes = np.hstack([blk[0] for blk in blocks])
    w2 = np.concatenate([blk[1] for blk in blocks])
    kinds = [kind for blk in blocks for kind in [blk[3]] * blk[0].shape[1]]
    n = shapes.shape[1]
    Gamma = np.zeros((n, n))
    i0 = 0
    for blk in blocks:
        k = blk[2].shape[0]
        Gamma[i0:i0 + k, i0:i0 + k] = blk[2]
        i0 += k
    order = np.argsort(w2, kind="stable")
    return (shapes[:, order], w2[order], Gamma[np.ix_(order, order)],
            np.asarray(kinds)[order])


def _inputs(fe, nm, shapes, measured, b):
    """``phib``: ``shapes^T b``, or the identified ``nm.phib`` on the measured modes and
    point forces at ``nm.actuators`` on the others, and whether those stay unexcited
    (``nm.actuators`` are not FE DOF labels)."""
    if b is not None:
        return shapes.T @ b, False
    phib = np.zeros((shapes.shape[1], nm.na))
    phib[measured] = nm.phib
    if nm.na and set(nm.actuators) <= set(fe.dofs):
        phib[~measured] = shapes[:, ~measured].T @ fe.point(list(nm.actuators))
        return phib, False
    return phib, bool(nm.na and np.any(~measured))
