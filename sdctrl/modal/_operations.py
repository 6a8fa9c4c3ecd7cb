"""Model-space algebra of normal-mode models: re-diagonalisation after changes.

``renormalised`` solves the reduced eigenproblem of ``mass p'' + Gamma p' + Omega p = phib u``
and returns the model on its new mass-normalised modes; :func:`modified` applies changes
given in modal coordinates (the reduced model of reanalysis, 4.17) and
:func:`with_feedback` closes collocated relative force loops (D-strut, 5.3-5.4).  The
functions take and return :class:`~sdctrl.modal._normal_model.NormalModeModel` objects (through
their ``replace``), and sit left of :mod:`sdctrl.modal._normal_model` in the flow so that its
methods can call them; changes given on physical DOFs are projected by
:func:`sdctrl.updating._reanalysis.reanalysis`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sdctrl._lib.statespace import second_order
from sdctrl._lib.validate import as_array, check_square

__all__ = ["gain", "io_kept", "modified", "poles", "renormalised", "sym_change",
           "with_feedback"]


def sym_change(x, name: str, n: int) -> np.ndarray:
    """Validated symmetric (n, n) change, zeros when ``x`` is None.

    Parameters
    ----------
    x : array_like, shape (n, n), or None
        The change.
    name : str
        Its name in error messages.
    n : int
        Number of modes.

    Returns
    -------
    ndarray, shape (n, n)
        ``(x + x^T) / 2``.
    """
    if x is None:
        return np.zeros((n, n))
    X = check_square(x, name, n)
    if np.abs(X - X.T).max() > 1e-8 * max(np.abs(X).max(), 1e-300):
        raise ValueError(f"{name} must be symmetric")
    return 0.5 * (X + X.T)


def renormalised(model, mass, Gamma, Omega, **info):
    """Normal modes of ``mass p'' + Gamma p' + Omega p = phib u`` (mass-normalised again).

    Solves ``Omega T = mass T diag(w^2)`` with ``T^T mass T = I`` and returns the model in
    the new coordinates ``p = T r``: ``Omega' = diag(w^2)``, ``Gamma' = T^T Gamma T``,
    ``cphi T``, ``T^T phib``, ``shapes T``.

    Parameters
    ----------
    model : NormalModeModel
        The model whose ``cphi``, ``phib`` and ``shapes`` are transformed.
    mass, Gamma, Omega : ndarray, shape (n, n)
        Modal mass, damping (rad/s) and stiffness ((rad/s)^2) in the model's coordinates.
    **info
        Entries added to the model's ``info``; ``T`` goes to its ``transformation``.

    Returns
    -------
    NormalModeModel
        Same class as ``model``.

    Raises
    ------
    ValueError
        ``mass`` is not positive definite.
    """
    import scipy.linalg as sla

    try:
        w2, T = sla.eigh(0.5 * (Omega + Omega.T), 0.5 * (mass + mass.T))
    except np.linalg.LinAlgError as exc:
        raise ValueError("the modified modal mass I + dmu must be positive definite") from exc
    G = T.T @ Gamma @ T
    return model.replace(
        Omega=np.diag(w2), Gamma=0.5 * (G + G.T), cphi=model.cphi @ T, phib=T.T @ model.phib,
        shapes=None if model.shapes is None else model.shapes @ T,
        info={**model.info, **info}, transformation=T)


def modified(model, dmu=None, dGamma=None, dOmega=None):
    """Model after reduced-coordinate changes (4.17), re-expressed on its own normal modes.

    ``(I + dmu) p'' + (Gamma + dGamma) p' + (Omega + dOmega) p = phib u``; the modified
    mass/stiffness pair is diagonalised again (``T^T (I + dmu) T = I``) so that the result
    keeps the mass-normalised form (``Omega`` diagonal, ``Gamma`` full).  For changes given on
    physical DOFs, ``dmu = phi^T dM phi`` etc. with ``phi`` = ``model.shapes``.

    Parameters
    ----------
    model : NormalModeModel
    dmu : array_like, shape (n, n), optional
        Modal mass change (symmetric).
    dGamma : array_like, shape (n, n), optional
        Modal damping change, rad/s (symmetric).
    dOmega : array_like, shape (n, n), optional
        Modal stiffness change, (rad/s)^2 (symmetric).

    Returns
    -------
    NormalModeModel
        ``transformation`` holds ``T`` (old modal coordinates = ``T`` new ones).

    Raises
    ------
    ValueError
        Wrong shapes, non-symmetric changes, or ``I + dmu`` not positive definite.
    """
    n = model.n
    dM = sym_change(dmu, "dmu", n)
    dG = sym_change(dGamma, "dGamma", n)
    dK = sym_change(dOmega, "dOmega", n)
    return renormalised(model, np.eye(n) + dM, model.Gamma + dG, model.Omega + dK,
                        modified=True)


def gain(k, m: int, name: str) -> np.ndarray:
    """Gain as an (m, m) matrix from a scalar, an (m,) vector or an (m, m) matrix.

    Parameters
    ----------
    k : float or array_like, shape (m,) or (m, m)
        The gain.
    m : int
        Number of loops.
    name : str
        Its name in error messages.

    Returns
    -------
    ndarray, shape (m, m)
    """
    g = as_array(k, name, ndim=(0, 1, 2))
    if g.ndim == 0:
        return float(g) * np.eye(m)
    if g.ndim == 1:
        if g.size != m:
            raise ValueError(f"{name} must be a scalar, ({m},) or ({m}, {m}), got {g.shape}")
        return np.diag(g)
    if g.shape != (m, m):
        raise ValueError(f"{name} must be a scalar, ({m},) or ({m}, {m}), got {g.shape}")
    return g


def with_feedback(model, b, c, kp=0.0, kv=0.0, modal: bool = False):
    """Closed loop of a relative force feedback ``F = -kv y' - kp y`` (D-strut, 5.3-5.4).

    With ``y = c q`` and the force entering as ``b F``, the modal equations become
    ``p'' + (Gamma + phib_k Kv cphi_k) p' + (Omega + phib_k Kp cphi_k) p = phib u`` where
    ``phib_k = phi^T b`` and ``cphi_k = c phi``.  A strut (``b = c^T``) keeps both matrices
    symmetric; the stiffened system is diagonalised again so ``Omega`` stays diagonal and the
    added damping shows as a full ``Gamma``.

    Parameters
    ----------
    model : NormalModeModel
    b : array_like, shape (N, k) or (n, k)
        Force input shapes on the DOFs of ``model.shapes``, or ``phi^T b`` if ``modal``.
    c : array_like, shape (k, N) or (k, n)
        Relative displacement measurements on those DOFs, or ``c phi`` if ``modal``.
    kp : float or array_like, shape (k,) or (k, k)
        Position gain (an added spring, force/displacement).
    kv : float or array_like, shape (k,) or (k, k)
        Velocity gain (an added dashpot, force/velocity).
    modal : bool
        True when ``b``, ``c`` are the modal ``phi^T b`` (n, k) and ``c phi`` (k, n).

    Returns
    -------
    NormalModeModel
        Same inputs and outputs as ``model``.

    Raises
    ------
    ValueError
        Shapes inconsistent with the model, ``modal=False`` on a model without ``shapes``, or
        a loop that is not collocated (``phi^T b K c phi`` not symmetric): close such loops
        with ``control.feedback`` on :meth:`NormalModeModel.to_statespace`.

    Notes
    -----
    The static term ``E`` of the model is not part of the loop: models that must see the
    residual flexibility at the strut carry static correction modes (2.22) as modes.
    """
    n = model.n
    if modal:
        pb = as_array(b, "b", ndim=2)
        cp = as_array(c, "c", ndim=2)
        if pb.shape[0] != n:
            raise ValueError(f"b must have shape (n={n}, k) when modal=True, got {pb.shape}")
        if cp.shape[1] != n:
            raise ValueError(f"c must have shape (k, n={n}) when modal=True, got {cp.shape}")
    else:
        if model.shapes is None:
            raise ValueError("the model has no shapes: give modal b = phi^T b and c = c phi "
                             "with modal=True")
        N = model.shapes.shape[0]
        bb = as_array(b, "b", ndim=(1, 2))
        cc = as_array(c, "c", ndim=(1, 2))
        bb = bb.reshape(-1, 1) if bb.ndim == 1 else bb
        cc = cc.reshape(1, -1) if cc.ndim == 1 else cc
        if bb.shape[0] != N:
            raise ValueError(f"b must have shape (N={N}, k), got {bb.shape}")
        if cc.shape[1] != N:
            raise ValueError(f"c must have shape (k, N={N}), got {cc.shape}")
        pb, cp = model.shapes.T @ bb, cc @ model.shapes
    k = pb.shape[1]
    if cp.shape[0] != k:
        raise ValueError(f"b has {k} force inputs but c has {cp.shape[0]} measurements")
    Kp, Kv = gain(kp, k, "kp"), gain(kv, k, "kv")
    dK, dC = pb @ Kp @ cp, pb @ Kv @ cp
    for name, X in (("kp", dK), ("kv", dC)):
        if np.abs(X - X.T).max() > 1e-8 * max(np.abs(X).max(), 1e-300):
            raise ValueError(f"the {name} loop is not collocated (phi^T b {name} c phi is not "
                             "symmetric): close it with control.feedback on to_statespace()")
    return renormalised(model, np.eye(n), model.Gamma + 0.5 * (dC + dC.T),
                        model.Omega + 0.5 * (dK + dK.T), feedback={"kp": Kp, "kv": Kv})


def poles(model) -> np.ndarray:
    """Poles of ``s^2 I + s Gamma + Omega`` (rad/s) with Im >= 0, sorted by modulus.

    Real (overdamped) poles are listed as well; for each underdamped mode only the
    upper half-plane pole is kept.

    Parameters
    ----------
    model : NormalModeModel
        The model.

    Returns
    -------
    ndarray, complex

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> nm = sd.NormalModeModel(np.diag([4.0]), np.diag([0.4]), [[1.0]], [[1.0]])
    >>> np.round(poles(nm), 4)
    array([-0.2+1.99j])
    """
    A = second_order(model.Omega, model.Gamma, model.phib, model.cphi)[0]
    lam = np.linalg.eigvals(A)
    scale = max(np.abs(lam).max(), 1.0)
    lam = lam[lam.imag >= -1e-12 * scale]
    return lam[np.argsort(np.abs(lam))]


def io_kept(model, sensors=None, actuators=None):
    """The model restricted to some of its outputs and inputs (a test without them).

    The modes are unchanged (``Omega``, ``Gamma``, ``shapes``); ``cphi`` keeps the rows of
    the kept sensors, ``phib`` the columns of the kept inputs, ``E`` and ``F`` both, and the
    residual dynamics (3.7) their residues at the kept I/O.  The statistics (``std``) are
    dropped.  Used for leave-one-out cross-validation on the test's channels
    (:func:`sdctrl.hybrid`, ``residual="auto"``).

    Parameters
    ----------
    model : NormalModeModel
        The model.
    sensors, actuators : array_like of int, optional
        Indices of the outputs and inputs kept (default: all).

    Returns
    -------
    NormalModeModel
        Same type; inputs are never modified.
    """
    s = np.arange(model.ns) if sensors is None else np.asarray(sensors, int).reshape(-1)
    a = np.arange(model.na) if actuators is None else np.asarray(actuators, int).reshape(-1)
    changes = {"cphi": model.cphi[s], "phib": model.phib[:, a], "std": None,
               "sensors": tuple(model.sensors[i] for i in s),
               "actuators": tuple(model.actuators[j] for j in a)}
    for name in ("E", "F"):
        v = getattr(model, name)
        changes[name] = None if v is None else np.asarray(v)[np.ix_(s, a)]
    res = model.residual
    if res is not None:
        R = res.placed(model.sensors, model.actuators)[:, s][:, :, a]
        changes["residual"] = replace(res, residues=R, sensors=changes["sensors"],
                                      actuators=changes["actuators"], residue_std=None)
    return model.replace(**changes)
