"""Closed loops through python-control and band-limited RMS responses.

- :func:`feedback` closes a user controller around a plant with
  ``control.interconnect`` so that every signal keeps its name (``control.feedback``
  drops them), python-control's sign convention ``u = w - K y``;
- a D-strut (5.3)-(5.4) ``F = -kv y' - kp y`` has one route, ``model.with_feedback``
  (:meth:`sdctrl.NormalModeModel.with_feedback`); a dynamic controller on a strut channel
  is closed with :func:`feedback` on ``model.with_io(...).to_statespace()``;
- :func:`rms` is the RMS of each output for independent band-limited white-noise inputs,
  integrated exactly over the band (closed form, no frequency sampling);
- :func:`modal_damping` lists the frequencies and damping ratios of the poles in a band.

Frequencies at the surface are in Hz, inside in rad/s.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.bandint import band_integral, band_integral_undamped
from sdctrl._lib.validate import as_array, check_band, check_finite_result, check_scalar
from sdctrl._lib.signals import as_statespace

__all__ = ["feedback", "modal_damping", "rms"]


# ----------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------
def _psd(psd, nu: int) -> np.ndarray:
    S = as_array(psd, "psd", ndim=(0, 1))
    if S.ndim == 0:
        S = np.full(nu, float(S))
    if S.shape != (nu,):
        raise ValueError(f"psd must be a scalar or one value per input ({nu},), got {S.shape}")
    if np.any(S < 0):
        raise ValueError("psd must be non-negative (one-sided PSD, units^2/Hz)")
    return S


def _mats(G):
    A, B, C, D = (np.asarray(X, float) for X in (G.A, G.B, G.C, G.D))
    return A, B, C, D


#: undamped poles: |Re p| below this fraction of |p| (a defective double pole at 0, a
#: rigid-body mode, splits by about sqrt(machine epsilon) in floating point: poles near 0
#: are judged against sqrt(max |p|) instead).  Relative to each pole, not to the largest
#: one: a stiff, overdamped pole (a strut's dashpot, a correction mode) must not make a
#: lightly damped mode look undamped.
AXIS_RTOL = 1e-7


def _on_axis(lam: np.ndarray, big: float):
    """Predicate ``(re, im) -> bool``: the poles on the imaginary axis (see AXIS_RTOL)."""
    floor = np.sqrt(max(big, 1.0))
    return lambda re, im: np.abs(re) <= AXIS_RTOL * np.maximum(np.hypot(re, im), floor)


def _check_poles(A: np.ndarray, w1: float, w2: float, what: str = "sys", lam=None):
    """Refuse poles that make the band RMS infinite or meaningless; returns None, or the
    predicate ``(re, im) -> bool`` of the undamped poles (imaginary axis) outside the band.
    ``lam``: the eigenvalues of ``A`` when the caller has them already."""
    if A.shape[0] == 0:
        return None
    lam = np.linalg.eigvals(A) if lam is None else lam
    on_axis = _on_axis(lam, float(np.abs(lam).max()))
    axis = on_axis(lam.real, lam.imag)
    unstable = (lam.real > 0) & ~axis
    if np.any(unstable):
        worst = lam[np.argmax(np.where(unstable, lam.real, -np.inf))]
        raise ValueError(f"{what} must be stable for a finite RMS response (pole {worst:.4g} "
                         "rad/s in the right half-plane); close a stabilising loop first")
    if not np.any(axis):
        return None
    w_axis = np.abs(lam[axis].imag)
    inside = (w_axis >= w1 * (1 - 1e-9)) & (w_axis <= w2 * (1 + 1e-9))
    if np.any(inside) or np.isinf(w2):
        f = w_axis[inside] if np.any(inside) else w_axis
        raise ValueError(f"{what} has undamped poles (on the imaginary axis) at "
                         f"{np.unique((f / (2 * np.pi)).round(6))[:5]} Hz: their band RMS is "
                         f"infinite over ({w1 / (2 * np.pi):g}, {w2 / (2 * np.pi):g}) Hz; give "
                         "a finite band that excludes them, or damp them (close the loop) first")
    return on_axis


# ----------------------------------------------------------------------------------------
# RMS
# ----------------------------------------------------------------------------------------
def rms(sys, band, psd=1.0) -> np.ndarray:
    """RMS of each output for independent band-limited white-noise inputs.

    Every input ``j`` carries white noise of one-sided PSD ``psd_j`` (units^2/Hz) limited
    to ``band`` (Hz); contributions of the inputs are summed:
    ``rms_i^2 = sum_j psd_j int_{f1}^{f2} |H_ij(2 pi j f)|^2 df``.

    The integral is evaluated exactly, without sampling frequencies (lightly damped peaks
    cannot be missed):

    - finite band: closed form (the frequency-limited Gramian, see Notes), evaluated by
      partial fractions in the eigenbasis of ``A`` (matrix logarithms and a Lyapunov
      solve when ``A`` is defective or its eigenvectors ill-conditioned);
    - ``band=(0, inf)``: the usual Lyapunov solution ``A P + P A^T + B S B^T = 0``,
      ``rms^2 = diag(C P C^T) / 2`` (one-sided PSD: half the H2 norm squared);
      ``(f1, inf)`` subtracts the finite band ``(0, f1)`` from it.

    Parameters
    ----------
    sys : control.StateSpace or model with ``to_statespace()``
        Continuous-time stable system (models are taken with displacement outputs).  Undamped
        poles (rigid-body modes, the double integrators of a residual mass, undamped modes)
        are allowed outside a finite band: the closed form is then taken with those poles
        moved slightly left and extrapolated back (``sdctrl._lib.bandint``).
    band : (float, float)
        ``(fmin, fmax)`` in Hz, ``0 <= fmin < fmax``; ``fmax`` may be ``numpy.inf``.
    psd : float or array_like, shape (n_inputs,)
        One-sided input PSD (units^2/Hz), the same for all inputs or one per input.

    Returns
    -------
    ndarray, shape (n_outputs,)
        RMS of each output (output units).

    Raises
    ------
    TypeError
        ``sys`` is not a system.
    ValueError
        Discrete-time or unstable system, undamped poles inside the band (or an infinite
        band), bad band or psd, or a feedthrough ``D`` with an infinite band (infinite RMS).

    Notes
    -----
    With ``R(w) = (j w I - A)^-1`` and ``Q = B S B^T``,
    ``int_{w1}^{w2} R Q R^H dw = X`` solves ``A X + X A^T = -(L Q + Q L^H)`` where
    ``L = int_{w1}^{w2} R dw = -j (log(j w2 I - A) - log(j w1 I - A))`` (W. Gawronski and
    J.-N. Juang, 1990).  The cross terms with ``D`` use ``L`` too and ``D S D^T`` adds
    ``(w2 - w1) D S D^T``.  Then ``rms^2 = diag(W) / (2 pi)``.

    Examples
    --------
    >>> import control, numpy as np
    >>> G = control.tf([1.0], [1.0, 0.2, 1.0])      # w0 = 1 rad/s, zeta = 0.1
    >>> full = rms(G, (0, np.inf))[0]
    >>> bool(np.isclose(full, np.sqrt(1 / (2 * 2 * 0.2))))
    True
    """
    G = as_statespace(sys)
    lo, hi = check_band(band, infinite=True)
    return rms_of_matrices(*_mats(G), (lo, hi), psd)


def rms_of_matrices(A, B, C, D, band, psd=1.0, lam=None) -> np.ndarray:
    """:func:`rms` of the system ``(A, B, C, D)`` (the kernel, no conversion).

    Parameters
    ----------
    A, B, C, D : ndarray
        State-space matrices (real).
    band : (float, float)
        Checked band (Hz), ``fmax`` may be ``numpy.inf``.
    psd : float or array_like
        One-sided input PSD, as for :func:`rms`.
    lam : ndarray, optional
        The eigenvalues of ``A`` when the caller has them already.

    Returns
    -------
    ndarray, shape (n_outputs,)
        RMS of each output.
    """
    S = _psd(psd, B.shape[1])
    w1, w2 = 2 * np.pi * band[0], 2 * np.pi * band[1]
    axis = _check_poles(A, w1, w2, lam=lam)
    try:
        with np.errstate(all="ignore"):
            if axis is None:
                return _rms(A, B, C, D, S, w1, w2)
            W = band_integral_undamped(A, B, C, D, S, w1, w2, axis)
            var = np.real(np.diag(W)) / (2 * np.pi)
            check_finite_result(var, "the RMS", "sys, band or psd")
            return np.sqrt(np.clip(var, 0.0, None))
    except np.linalg.LinAlgError as exc:
        raise ValueError(f"sys: the band integral failed ({exc}); the system is too badly "
                         "conditioned (scale its states or matrices)") from None


def appended_block(A2, B2, C2, D, band, psd=1.0):
    """The fixed block of :func:`rms_appended` (:func:`sdctrl._lib.bandappend.fixed_block`).

    Parameters
    ----------
    A2, B2, C2 : ndarray
        Realisation of the part of a system no candidate changes.
    D : ndarray
        Feedthrough of the assembled systems.
    band : (float, float)
        Band (Hz), finite.
    psd : float or array_like
        One-sided input PSD, as for :func:`rms`.

    Returns
    -------
    FixedBlock
    """
    from sdctrl._lib.bandappend import fixed_block

    S = _psd(psd, B2.shape[1])
    w1, w2 = 2 * np.pi * band[0], 2 * np.pi * band[1]
    axis = _check_poles(A2, w1, w2, "the model's fixed part")
    return fixed_block(A2, B2, C2, D, S, w1, w2, undamped=axis is not None)


def rms_appended(A1, B1, C1, fixed, lam=None) -> np.ndarray:
    """:func:`rms` of ``(diag(A1, A2), [B1; B2], [C1, C2], D)`` with the block ``fixed``
    (:func:`appended_block`) shared by many systems: the same numbers as
    :func:`rms_of_matrices` of the assembled system, without its matrix logarithms.

    Parameters
    ----------
    A1, B1, C1 : ndarray
        The changed block.
    fixed : FixedBlock
        The rest.
    lam : ndarray, optional
        Eigenvalues of ``A1`` when the caller has them.

    Returns
    -------
    ndarray, shape (n_outputs,)
    """
    from sdctrl._lib.bandappend import band_integral_appended

    w1, w2 = fixed.band
    axis = _check_poles(A1, w1, w2, lam=lam)
    W = None if axis is not None else band_integral_appended(A1, B1, C1, fixed)
    if W is None:
        k = A1.shape[0]
        A = np.zeros((k + fixed.A.shape[0],) * 2)
        A[:k, :k], A[k:, k:] = A1, fixed.A
        lam_all = None if lam is None else np.concatenate([lam, fixed.lam])
        return rms_of_matrices(A, np.vstack([B1, fixed.B]), np.hstack([C1, fixed.C]),
                               fixed.D, (w1 / (2 * np.pi), w2 / (2 * np.pi)), fixed.S,
                               lam=lam_all)
    var = np.real(np.diag(W)) / (2 * np.pi)
    check_finite_result(var, "the RMS", "sys, band or psd")
    return np.sqrt(np.clip(var, 0.0, None))


def _rms(A, B, C, D, S, w1: float, w2: float) -> np.ndarray:
    """RMS of each output over ``(w1, w2)`` rad/s (``w2`` may be inf); see :func:`rms`."""
    if np.isinf(w2):
        if np.any(D[:, S > 0] != 0):
            raise ValueError("sys has a feedthrough D: white noise over an infinite band gives "
                             "an infinite RMS; give a finite band")
        from scipy.linalg import solve_continuous_lyapunov

        if A.shape[0]:
            P = solve_continuous_lyapunov(A, -(B * S) @ B.T)
            var = np.pi * np.diag(C @ P @ C.T)              # int_0^inf = pi diag(C P C^T)
        else:
            var = np.zeros(C.shape[0])
        if w1 > 0:
            var = var - np.real(np.diag(band_integral(A, B, C, D, S, 0.0, w1)))
    else:
        var = np.real(np.diag(band_integral(A, B, C, D, S, w1, w2)))
    var = var / (2 * np.pi)
    check_finite_result(var, "the RMS", "sys, band or psd")
    return np.sqrt(np.clip(var, 0.0, None))


# ----------------------------------------------------------------------------------------
# poles in a band
# ----------------------------------------------------------------------------------------
def modal_damping(sys, band=None):
    """Natural frequencies (Hz) and damping ratios of the poles of ``sys`` in ``band``.

    Parameters
    ----------
    sys : control.StateSpace or model with ``poles`` / ``to_statespace()``
        The system.
    band : (float, float), optional
        Keep poles whose natural frequency ``|p| / 2 pi`` lies in ``band`` (Hz).

    Returns
    -------
    frequency : ndarray
        ``|p| / 2 pi`` in Hz, increasing (one entry per complex pair, Im p >= 0).
    damping : ndarray
        ``-Re p / |p|``.
    """
    if hasattr(sys, "poles") and not callable(sys.poles):
        p = np.asarray(sys.poles)
    else:
        p = np.asarray(as_statespace(sys).poles())
        p = p[p.imag >= -1e-12 * max(np.abs(p).max(initial=0.0), 1.0)]
    f = np.abs(p) / (2 * np.pi)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(np.abs(p) > 0, -p.real / np.abs(p), 1.0)
    if band is not None:
        lo, hi = check_band(band, infinite=True)
        keep = (f >= lo) & (f <= hi)
        f, z = f[keep], z[keep]
    order = np.argsort(f)
    return f[order], z[order]


# ----------------------------------------------------------------------------------------
# closing loops with names kept
# ----------------------------------------------------------------------------------------
def _default_names(labels, prefix: str) -> bool:
    return all(lab == f"{prefix}[{i}]" for i, lab in enumerate(labels))


def feedback(plant, controller, sign: float = -1.0, *, control_outputs: bool = False):
    """Close ``controller`` around ``plant`` with ``control.interconnect``, names kept.

    The controller reads plant outputs and drives plant inputs, matched by signal name:
    its input names are plant output names, its output names plant input names (a
    controller with python-control's default names ``u[i]``/``y[i]`` and the plant's full
    dimensions is matched by position).  Each driven plant input becomes
    ``u = w + sign * K y`` (default ``sign=-1``: ``u = w - K y``, python-control's
    negative feedback), where ``w`` is the external input of the same name.

    Parameters
    ----------
    plant : control.StateSpace or model with ``to_statespace()``
        Plant with named inputs and outputs.
    controller : control.StateSpace or TransferFunction
        From (some) plant outputs to (some) plant inputs.
    sign : float
        Feedback sign, -1 (negative, default) or +1.
    control_outputs : bool
        Also output the controller signals, named ``"<input>_ctrl"``.

    Returns
    -------
    control.StateSpace
        Inputs: the plant's inputs (external forces ``w``); outputs: the plant's outputs
        (and controller outputs); states: plant then controller states.

    Raises
    ------
    ValueError
        Controller signals that match no plant signal.

    Examples
    --------
    >>> import control
    >>> P = control.ss([[0, 1], [-1, -0.02]], [[0], [1]], [[1, 0]], 0,
    ...                inputs=["x_u"], outputs=["x"])          # sdctrl's names
    >>> K = control.ss([], [], [], [[3.0]], inputs=["x"], outputs=["x_u"])
    >>> cl = feedback(P, K)
    >>> cl.input_labels, cl.output_labels
    (['x_u'], ['x'])
    """
    import control

    P = as_statespace(plant, "plant")
    K = as_statespace(controller, "controller")
    if check_scalar(sign, "sign") not in (-1.0, 1.0):
        raise ValueError(f"sign must be -1 or +1, got {sign!r}")
    pin, pout = list(P.input_labels), list(P.output_labels)
    kin, kout = list(K.input_labels), list(K.output_labels)
    if (_default_names(kin, "u") and _default_names(kout, "y") and len(kin) == len(pout)
            and len(kout) == len(pin)):
        kin, kout = pout, pin
    for lab in kin:
        if lab not in pout:
            raise ValueError(f"controller input {lab!r} is not a plant output {pout}")
    for lab in kout:
        if lab not in pin:
            raise ValueError(f"controller output {lab!r} is not a plant input {pin}")
    if len(set(kin)) != len(kin) or len(set(kout)) != len(kout):
        raise ValueError("controller signal names must be unique")
    # internal names: plant inputs/outputs may share labels (collocated pairs)
    ui = [f"u{i}" for i in range(len(pin))]
    yi = [f"y{i}" for i in range(len(pout))]
    ki = [f"k{pin.index(lab)}" for lab in kout]
    wi = [f"w{i}" for i in range(len(pin))]
    Pn = control.ss(P.A, P.B, P.C, P.D, inputs=ui, outputs=yi, name="plant")
    Kn = control.ss(K.A, K.B, K.C, K.D, inputs=[f"y{pout.index(lab)}" for lab in kin],
                    outputs=ki, name="controller")
    Dsum = np.hstack([np.eye(len(pin)), np.zeros((len(pin), len(kout)))])
    for j, lab in enumerate(kout):
        Dsum[pin.index(lab), len(pin) + j] = float(sign)
    Sum = control.ss(np.zeros((0, 0)), np.zeros((0, Dsum.shape[1])),
                     np.zeros((len(pin), 0)), Dsum, inputs=wi + ki, outputs=ui, name="sum")
    outlist, outnames = list(yi), list(pout)
    if control_outputs:
        outlist += ki
        outnames += [f"{lab}_ctrl" for lab in kout]
    return control.interconnect([Pn, Kn, Sum], inplist=wi, outlist=outlist, inputs=pin,
                                outputs=outnames, name="closed_loop")
