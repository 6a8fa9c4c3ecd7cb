"""Expansion of measured modes onto FE DOFs (thesis 4.1.1, eq. 4.7) and FE/test mode
pairing by the MAC (4.9).

The test measures the modal observabilities ``(c phi)_ID`` at its sensors only; the FE
model gives shapes on all its DOFs.  Pairing matches each test mode with the FE mode of
largest MAC (one FE mode per test mode, maximal total MAC); the geometric expansion (4.7)
combines the paired FE shapes to fit the measured ones at the sensors,
``phi_Ex = phi_FE (c phi_FE)^+ (c phi)_ID``; :func:`expand_regularised` does the same on a
richer basis (more FE modes than test modes, static shapes) with the smoothing of section
4.1.1 made explicit as a prior.  They serve the hybrid models of chapter V
(:func:`sdctrl.hybrid`) and the correlation of FE and test modes in updating.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.validate import as_array, check_scalar
from sdctrl.updating._costs import mac

__all__ = ["MAC_POOR", "expand", "expand_regularised", "loo_prior", "pair_modes"]

#: MAC below which a FE/test pair is reported as poor (with a warning)
MAC_POOR = 0.8
#: an FE mode more than this factor away in frequency is not paired with a test mode that
#: has a nearer one (:func:`pair_modes`)
PAIR_RATIO = 2.0


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


def expand_regularised(basis, lam, c, cphi_id, pair, *, spread: float | None = None,
                       noise: float | None = None):
    """Expansion (4.7) on a rich basis, regularised by the perturbation prior of 4.1.1.

    Each measured mode is sought as ``phi_Ex_j = T a_j`` on a basis ``T`` richer than the
    paired FE modes (all FE modes of a band, static shapes), so that the measured
    observabilities are matched where the paired modes alone cannot.  The smoothing that
    section 4.1.1 asks of ``A`` is made explicit: a Gaussian prior centred on the paired
    FE mode, ``a_j ~ N(a0_j, diag(sigma_j^2))`` with ``a0_j = alpha_j e_p`` (``alpha_j`` the
    least-squares scale of the paired shape ``p``) and, from first-order perturbation
    (a true mode recombines the FE modes with weights ``~ phi_k^T dK phi_p / (lambda_p -
    lambda_k)``), ``sigma_jk = |alpha_j| min(1, spread lambda_p / |lambda_p - lambda_k|)``;
    the data ``(c phi)_ID`` carry a noise of relative level ``noise``.  The posterior mean

    ``a_j = a0_j + S G^T (G S G^T + s_j^2 I)^-1 ((c phi)_ID,j - G a0_j)``,
    ``G = c T``, ``S = diag(sigma_j^2)``, ``s_j = noise ||(c phi)_ID,j|| / sqrt(ns)``,

    is the least-squares fit (4.7) when the basis is the paired modes alone and the noise
    vanishes, and otherwise the fit that departs least (in the prior's metric) from the
    paired FE mode.  With a basis richer than the sensors it interpolates the measured
    observabilities up to ``noise``; basis vectors far in frequency from the paired mode
    are used little.

    The spread and the noise level set how far the fit may leave the paired FE shape to
    follow the measured observabilities, hence what the expanded shapes predict at the
    DOFs without a sensor: too broad a prior or too small a noise interpolates the
    identification errors of ``(c phi)_ID`` and the FE's errors, and spreads them, through
    the rich basis, over the unmeasured DOFs (a fixed ``spread=1, noise=1e-4`` did so).
    By default both are chosen, per mode, from the data by leave-one-sensor-out
    cross-validation (:func:`loo_prior`): the prior whose fit on all the other sensors
    best predicts each sensor's observabilities -- the very use of the expanded shapes at
    an untested DOF.

    Parameters
    ----------
    basis : array_like, shape (N, m)
        The basis ``T`` (FE modes, static shapes), e.g. mass-orthonormal.
    lam : array_like, shape (m,)
        Eigenvalues (rad/s)^2 of the basis vectors (``phi^T K phi`` of static shapes).
    c : array_like, shape (ns, N)
        Test sensors on the FE DOFs.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities.
    pair : array_like of int, shape (n,)
        Column of ``basis`` paired with each measured mode (:func:`pair_modes`).
    spread : float or array_like of shape (n,), optional
        Prior spread of the recombination (relative FE error level), one or per mode;
        default chosen per mode with ``noise`` by leave-one-sensor-out cross-validation
        (:func:`loo_prior`).
    noise : float or array_like of shape (n,), optional
        Relative noise level of the identified observabilities; default likewise.

    Returns
    -------
    shapes : ndarray, shape (N, n)
        Expanded shapes ``T A``.
    A : ndarray, shape (m, n)
        Combination coefficients.

    Examples
    --------
    >>> import numpy as np
    >>> T = np.eye(4)[:, :3]
    >>> c = np.eye(4)[:2]
    >>> shapes, A = expand_regularised(T, [1.0, 4.0, 100.0], c, [[1.0], [0.2]], [0],
    ...                                spread=1.0, noise=1e-4)
    >>> np.round(A[:, 0], 3).tolist()               # mode 1 recombined, mode 3 unobserved
    [1.0, 0.2, 0.0]
    """
    T = as_array(basis, "basis", ndim=2)
    lam = as_array(lam, "lam", shape=(T.shape[1],))
    Cm = as_array(c, "c", ndim=2)
    Y = as_array(cphi_id, "cphi_id", ndim=2)
    p = np.asarray(pair, dtype=int).reshape(-1)
    if Cm.shape[1] != T.shape[0]:
        raise ValueError(f"c must have shape (ns, N={T.shape[0]}), got {Cm.shape}")
    if Y.shape[0] != Cm.shape[0] or p.size != Y.shape[1]:
        raise ValueError(f"cphi_id must have shape (ns={Cm.shape[0]}, n) with n = len(pair)")
    if np.any(p < 0) or np.any(p >= T.shape[1]):
        raise ValueError("pair: index out of the basis")
    G = Cm @ T
    ns = G.shape[0]
    if spread is None or noise is None:
        spread, noise = loo_prior(G, lam, Y, p, spread=spread, noise=noise)
    if np.ndim(spread) == 0:
        spread = check_scalar(spread, "spread", positive=True)
    if np.ndim(noise) == 0:
        noise = check_scalar(noise, "noise", positive=True)
    spread, noise = (np.broadcast_to(np.asarray(v, float), (p.size,)) for v in (spread, noise))
    if not (np.all(np.isfinite(spread) & (spread > 0)) and np.all(np.isfinite(noise)
                                                                  & (noise > 0))):
        raise ValueError("spread and noise must be positive and finite (one or per mode)")
    S, A0 = _prior(G, lam, Y, p, spread)
    s2 = (noise * np.linalg.norm(Y, axis=0)) ** 2 / ns
    K = np.einsum("ik,jk,nk->nij", G, G, S) + s2[:, None, None] * np.eye(ns)
    R = (Y - G @ A0).T[:, :, None]                                         # (n, ns, 1)
    A = A0 + (S * np.einsum("ik,nil->nk", G, np.linalg.solve(K, R))).T
    return T @ A, A


def _prior(G, lam, Y, p, spread):
    """Prior variances ``S`` (n, m) and means ``A0`` (m, n) of :func:`expand_regularised`."""
    m = G.shape[1]
    gp = G[:, p]
    alpha = np.einsum("ij,ij->j", gp, Y) / np.maximum(np.einsum("ij,ij->j", gp, gp), 1e-300)
    lp = lam[p][:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.reshape(spread, (-1, 1)) * np.abs(lp) / np.abs(lp - lam[None, :])
    sig = np.minimum(np.nan_to_num(ratio, nan=1.0, posinf=1.0), 1.0)      # (n, m)
    sig[np.arange(p.size), p] = 1.0
    S = (sig * np.abs(alpha)[:, None]) ** 2
    A0 = np.zeros((m, p.size))
    A0[p, np.arange(p.size)] = alpha
    return S, A0


#: candidate prior spreads and relative noise levels of the cross-validation
SPREADS = np.logspace(-2.0, 0.5, 11)
NOISES = np.logspace(-4.0, 0.0, 17)


def loo_prior(G, lam, Y, pair, *, spread=None, noise=None):
    """Prior spread and noise level of :func:`expand_regularised` by leave-one-sensor-out
    cross-validation.

    For the Gaussian model of :func:`expand_regularised` (prior covariance ``S_j`` of the
    coefficients of mode ``j``, data covariance ``K_j = G S_j G^T + s_j^2 I``), the
    prediction of sensor ``i`` from the fit on all the other sensors misses it by
    ``e_ij = [K_j^-1 y_j]_i / [K_j^-1]_ii``, in closed form.  The prior mean (the paired
    shape scaled on every sensor) is turned into a zero mean with its own variance added,
    so that no sensor takes part in its own prediction.  The pair (``spread``, ``noise``)
    minimising ``||e_j||^2`` on the grids :data:`SPREADS` x :data:`NOISES` is chosen for
    each mode: the prior that best predicts the mode's shape at a DOF without a sensor,
    the use the expanded shapes are made for.

    Parameters
    ----------
    G : ndarray, shape (ns, m)
        Basis at the sensors, ``c T``.
    lam : ndarray, shape (m,)
        Eigenvalues of the basis vectors.
    Y : ndarray, shape (ns, n)
        Identified observabilities.
    pair : ndarray of int, shape (n,)
        Paired basis vector of each mode.
    spread, noise : float, optional
        Either held fixed (the other is cross-validated).

    Returns
    -------
    spread, noise : ndarray, shape (n,)
        Per mode.
    """
    spreads = SPREADS if spread is None else np.array([float(spread)])
    noises = NOISES if noise is None else np.array([float(noise)])
    ns, n = Y.shape
    nrm2 = np.maximum(np.sum(Y**2, axis=0), 1e-300)
    cost = np.zeros((spreads.size, noises.size, n))
    for i, sp in enumerate(spreads):
        S, A0 = _prior(G, lam, Y, pair, sp)
        S = S + (A0**2).T
        K = np.einsum("ik,nk,jk->nij", G, S, G)                       # K_j, all modes
        d, Q = np.linalg.eigh(0.5 * (K + K.transpose(0, 2, 1)))
        D = (np.clip(d, 0, None)[:, None, :]
             + (noises**2)[None, :, None] * (nrm2 / ns)[:, None, None])   # (n, noise, ns)
        qy = np.einsum("nij,in->nj", Q, Y)                            # Q_j^T y_j
        e = (np.einsum("nvk,nik->nvi", qy[:, None, :] / D, Q)
             / np.einsum("nvk,nik->nvi", 1.0 / D, Q**2))
        cost[i] = (np.sum(e**2, axis=2) / nrm2[:, None]).T
    i, j = np.unravel_index(np.argmin(cost.reshape(-1, n), axis=0), cost.shape[:2])
    return spreads[i], noises[j]


def pair_modes(cphi_fe, cphi_id, f_fe=None, f_id=None, ratio: float = PAIR_RATIO):
    """Pair test modes with FE modes by maximal total MAC (4.9), one FE mode per test mode.

    With the frequencies given, a test mode is paired only with FE modes within a factor
    ``ratio`` of its frequency (when it has any): at a few tens of sensors a far mode can
    reach a larger MAC by chance (a 48 Hz test mode with a 246 Hz FE mode, MAC 0.63, on the
    ladder), while an FE model off by a factor ``ratio`` in frequency is not a model of
    that mode.  The MAC of each pair is reported as is.

    Parameters
    ----------
    cphi_fe : array_like, shape (ns, m)
        FE modal observabilities at the test sensors, ``m >= n``.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities.
    f_fe : array_like, shape (m,), optional
        FE frequencies (Hz).
    f_id : array_like, shape (n,), optional
        Test frequencies (Hz).
    ratio : float
        Largest frequency ratio of a pair (both given).

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

    macs = mac(cphi_fe, cphi_id)
    score = macs.copy()
    if f_fe is not None and f_id is not None:
        f_fe, f_id = np.asarray(f_fe, float), np.asarray(f_id, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            far = np.abs(np.log(f_fe[:, None] / f_id[None, :])) > np.log(ratio)
        far &= ~np.all(far, axis=0, keepdims=True)     # a mode with no near FE mode: any
        score[far] -= 2.0                               # below every MAC in [0, 1]
    rows, cols = linear_sum_assignment(-score)
    index = np.empty(macs.shape[1], int)
    index[cols] = rows
    return index, macs[index, np.arange(macs.shape[1])], macs
