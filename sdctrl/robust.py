"""Robust stability of the closed loop over the structured uncertainty of section 5.2.

Mixed real structured singular value: upper bound with D-G scalings (an LMI solved by cvxpy/Clarabel
per frequency, re-certified by the exact generalised eigenvalue), lower bound by a search over real
destabilising perturbations (vertices, random directions and a 1-D stability sweep along each).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from sdctrl._progress import progress_bar
from sdctrl._statespace import ss_frf

__all__ = [
    "RobustResult",
    "certify_dg",
    "closed_loop_lft",
    "mu_upper",
    "robust_stability",
    "worst_case_gain",
]


@dataclass(frozen=True, eq=False)
class RobustResult:
    """Result of :func:`robust_stability`.

    Parameters
    ----------
    margin : float
        1/upper bound of mu: the loop is stable for every Delta up to ``margin`` times the bounds.
    margin_lower : float
        Size (max-norm of the normalised parameters) of the smallest destabilising Delta found.
    stable : bool
        Nominal closed-loop stability.
    frequency : float
        Critical frequency (Hz) of the mu upper bound peak.
    worst_delta : ndarray
        Destabilising normalised parameters found (size ``margin_lower``).
    mu_freq : ndarray
        Frequencies (Hz) of the mu upper bound curve.
    mu : ndarray
        Mu upper bound at ``mu_freq``.
    info : dict
        Diagnostics (number of frequencies, lower bound of mu).
    """

    margin: float
    margin_lower: float
    stable: bool
    frequency: float
    worst_delta: np.ndarray
    mu_freq: np.ndarray
    mu: np.ndarray
    info: dict

    def __repr__(self) -> str:
        return (f"RobustResult(margin={self.margin:.4g}, margin_lower={self.margin_lower:.4g}, "
                f"stable={self.stable}, frequency={self.frequency:.4g} Hz, "
                f"{len(self.worst_delta)} blocks, {len(self.mu_freq)} frequencies)")


def closed_loop_lft(um, controller):
    """Closed-loop matrices ``(A, Bw, Cz, Dzw)`` of the Delta channels with ``u = -K y``.

    Parameters
    ----------
    um : UncertainModel
        Uncertain model.
    controller : control.StateSpace
        Controller from the model's outputs to its inputs.

    Returns
    -------
    tuple of ndarray
    """
    A, Bw, Bu, Cz, Dzu, Cy, Dyw, D = um._lft_matrices()
    K = controller
    Ak, Bk, Ck, Dk = (np.atleast_2d(np.asarray(x, float)) for x in (K.A, K.B, K.C, K.D))
    ns, na = Cy.shape[0], Bu.shape[1]
    if Dk.shape != (na, ns):
        raise ValueError(f"controller must map the model's {ns} outputs to its {na} inputs, "
                         f"got a {Dk.shape[1]}-input {Dk.shape[0]}-output system")
    nk = Ak.shape[0] if Ak.size else 0
    nx = A.shape[0]
    Ak = Ak.reshape(nk, nk)
    Bk = Bk.reshape(nk, ns)
    Ck = Ck.reshape(na, nk)
    F = np.linalg.inv(np.eye(na) + Dk @ D)
    # u = Ux X + Uw w with X = [x; xk]
    Ux = F @ np.hstack([-Dk @ Cy, -Ck])
    Uw = -F @ Dk @ Dyw
    Yx = np.hstack([Cy, np.zeros((ns, nk))]) + D @ Ux
    Yw = Dyw + D @ Uw
    Acl = np.block([[A, np.zeros((nx, nk))], [np.zeros((nk, nx)), Ak]])
    Acl = Acl + np.vstack([Bu, np.zeros((nk, na))]) @ Ux + np.vstack([np.zeros((nx, ns)), Bk]) @ Yx
    Bcl = np.vstack([Bw, np.zeros((nk, Bw.shape[1]))]) + np.vstack([Bu, np.zeros((nk, na))]) @ Uw \
        + np.vstack([np.zeros((nx, ns)), Bk]) @ Yw
    Ccl = np.hstack([Cz, np.zeros((Cz.shape[0], nk))]) + Dzu @ Ux
    Dcl = Dzu @ Uw
    return Acl, Bcl, Ccl, Dcl


def _frf(A, B, C, D, w):
    return ss_frf(A, B, C, D, np.asarray(w, float))


def certify_dg(M, D, G):
    """Exact mu upper bound certified by scalings ``(D, G)``: the smallest ``beta`` with
    ``M^H D M + j(G M - M^H G) - beta^2 D <= 0`` (generalised eigenvalue).

    Parameters
    ----------
    M : ndarray (r, r)
        Complex matrix.
    D : ndarray (r, r)
        Hermitian positive definite scaling (block structure of Delta).
    G : ndarray (r, r)
        Hermitian scaling, zero on complex blocks.

    Returns
    -------
    float
    """
    X = M.conj().T @ D @ M + 1j * (G @ M - M.conj().T @ G)
    X = 0.5 * (X + X.conj().T)
    lam = sla.eigh(X, 0.5 * (D + D.conj().T), eigvals_only=True)
    return float(np.sqrt(max(lam[-1], 0.0)))


def _structure(reps, eps):
    """Block index lists; reals first then (if eps>0) their complex regularising copies."""
    idx, k = [], 0
    for r in reps:
        idx.append(list(range(k, k + r)))
        k += r
    real = [(i, True) for i in idx]
    cplx = [([k + j for j in i], False) for i in idx] if eps > 0 else []
    return real + cplx, k


def _herm_var(cp, r):
    Re = cp.Variable((r, r), symmetric=True)
    Im = cp.Variable((r, r))
    return Re, Im


def mu_upper(M, reps, eps: float = 0.01, rtol: float = 0.005, lower: float = 0.0):
    """Mixed real mu upper bound of ``M`` for repeated real scalar blocks (D-G scalings).

    Each real ``delta`` is regularised as ``delta + eps*delta_c`` (a small complex part), so the
    bound is continuous in frequency (conservatism about ``1 + eps``).  ``M`` is scaled to unit norm
    before the LMI is solved by cvxpy (Clarabel) within a bisection; every returned (D, G) is
    re-certified by :func:`certify_dg`.

    Parameters
    ----------
    M : ndarray (r, r)
        Complex matrix (closed-loop Delta-channel response at one frequency).
    reps : sequence of int
        Repetition of each real scalar block (channel order).
    eps : float
        Relative complex regularisation.
    rtol : float
        Relative tolerance of the bisection (stopped anyway below ``1e-3 ||M||``).
    lower : float
        Value of interest: if the bound is certified below it after one solve, that certificate
        is returned at once (no bisection); otherwise the bisection searches above it.

    Returns
    -------
    bound : float
        Certified upper bound.
    scalings : tuple
        ``(Maug, D, G)`` certifying the bound on the augmented matrix.
    """
    import cvxpy as cp
    M = np.asarray(M, complex)
    M.shape[0]
    if eps > 0:
        Maug = np.block([[M, M], [eps * M, eps * M]])
    else:
        Maug = M
    blocks, _ = _structure(reps, eps)
    nrm = np.linalg.norm(Maug, 2)
    if nrm == 0:
        return 0.0, (Maug, np.eye(Maug.shape[0]), np.zeros(Maug.shape))
    Ms = Maug / nrm
    N = Ms.shape[0]
    # real embedding of Hermitian matrices: H = Re + j Im  <->  [[Re, -Im], [Im, Re]]
    DRe = cp.Variable((N, N), symmetric=True)
    DIm = cp.Variable((N, N))
    GRe = cp.Variable((N, N), symmetric=True)
    GIm = cp.Variable((N, N))
    cons = [DIm == -DIm.T, GIm == -GIm.T]
    mask = np.zeros((N, N))
    gmask = np.zeros((N, N))
    for ii, isreal in blocks:
        for a in ii:
            for b in ii:
                mask[a, b] = 1
                if isreal:
                    gmask[a, b] = 1
    cons += [cp.multiply(1 - mask, DRe) == 0, cp.multiply(1 - mask, DIm) == 0,
             cp.multiply(1 - gmask, GRe) == 0, cp.multiply(1 - gmask, GIm) == 0]
    Mr, Mi = Ms.real, Ms.imag
    # X = M^H D M + j(G M - M^H G) - t D
    Dm = DRe + 0  # noqa
    # complex products via real parts: (a+jb)(c+jd)
    def mul(Ar, Ai, Br, Bi):
        return Ar @ Br - Ai @ Bi, Ar @ Bi + Ai @ Br
    MhR, MhI = Mr.T, -Mi.T
    t1r, t1i = mul(DRe, DIm, Mr, Mi)
    q1r, q1i = mul(MhR, MhI, t1r, t1i)
    g1r, g1i = mul(GRe, GIm, Mr, Mi)
    g2r, g2i = mul(MhR, MhI, GRe, GIm)
    # j*(g1 - g2) = -(g1i - g2i) + j (g1r - g2r)
    t = cp.Parameter(nonneg=True)
    Xr = q1r - (g1i - g2i) - t * DRe
    Xi = q1i + (g1r - g2r) - t * DIm
    big = cp.bmat([[Xr, -Xi], [Xi, Xr]])
    Dbig = cp.bmat([[DRe, -DIm], [DIm, DRe]])
    cons += [0.5 * (big + big.T) << 0, 0.5 * (Dbig + Dbig.T) >> np.eye(2 * N),
             0.5 * (Dbig + Dbig.T) << 1e6 * np.eye(2 * N)]
    prob = cp.Problem(cp.Minimize(0), cons)

    def scal():
        Dv = DRe.value + 1j * DIm.value
        Gv = GRe.value + 1j * GIm.value
        Dv = 0.5 * (Dv + Dv.conj().T) * mask
        Gv = 0.5 * (Gv + Gv.conj().T) * gmask
        return Dv, Gv

    # initial upper: plain norm (D = I, G = 0) certified = 1
    best = 1.0
    best_sc = (np.eye(N), np.zeros((N, N)))
    lo = 0.0
    hi = best
    if lower > 0 and lower / nrm < 1.0:
        # only values above ``lower`` matter to the caller: one solve certifies "mu <= lower"
        t.value = (lower / nrm) ** 2
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL)
            if prob.status in ("optimal", "optimal_inaccurate") and DRe.value is not None:
                Dv, Gv = scal()
                cert = certify_dg(Ms, Dv, Gv)
                if cert < best:
                    best, best_sc = cert, (Dv, Gv)
                    hi = cert
                if cert <= (lower / nrm) * (1 + rtol):
                    return best * nrm, (Maug, best_sc[0], best_sc[1] * nrm)
            lo = lower / nrm
        except (cp.error.SolverError, np.linalg.LinAlgError, ValueError):
            pass
    while hi - lo > rtol * hi and hi > 1e-3:  # absolute floor: 1e-3 of ||M||
        mid = 0.5 * (lo + hi)
        t.value = mid ** 2
        try:
            with warnings.catch_warnings():  # "inaccurate" is handled by the re-certification
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL)
            ok = prob.status in ("optimal", "optimal_inaccurate") and DRe.value is not None
        except cp.error.SolverError:
            ok = False
        if ok:
            Dv, Gv = scal()
            try:
                cert = certify_dg(Ms, Dv, Gv)
            except (np.linalg.LinAlgError, ValueError):
                cert = np.inf
            if cert < best:
                best, best_sc = cert, (Dv, Gv)
            hi = min(max(cert, mid), hi)  # certified value; never trust the solver status alone
            if cert > mid * (1 + 2 * rtol):
                lo = mid  # solver claimed feasibility the certificate does not confirm
        else:
            lo = mid
    # (D, G*nrm) certify best*nrm on the unscaled augmented matrix
    return best * nrm, (Maug, best_sc[0], best_sc[1] * nrm)


def _stab_along(Acl, Bcl, Ccl, Dcl, expand, direction, amax, n_grid=40):
    """Smallest alpha in (0, amax] making the loop unstable along ``direction`` (1-D sweep + bisection)."""
    def unstable(a):
        Dl = np.diag(expand @ (a * direction))
        Mi = np.eye(Dl.shape[0]) - Dl @ Dcl
        try:
            X = np.linalg.solve(Mi, Dl @ Ccl)
        except np.linalg.LinAlgError:
            return True, 0.0
        ev = np.linalg.eigvals(Acl + Bcl @ X)
        k = np.argmax(ev.real)
        return ev[k].real >= 0, abs(ev[k].imag)
    grid = np.linspace(0, amax, n_grid + 1)[1:]
    prev = 0.0
    for a in grid:
        u, _ = unstable(a)
        if u:
            lo, hi = prev, a
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if unstable(mid)[0]:
                    hi = mid
                else:
                    lo = mid
            return hi, unstable(hi)[1]
        prev = a
    return np.inf, np.nan


def robust_stability(um, controller, freq=None, eps: float = 0.01, n_directions: int = 20,
                     seed: int = 0, progress: bool | None = None) -> RobustResult:
    """Robust stability margin of ``u = -K y`` over the structured uncertainty (5.5).

    Parameters
    ----------
    um : UncertainModel
        Uncertain model (see :func:`sdctrl.uncertainty.uncertain`).
    controller : control.StateSpace
        Controller from the model's outputs to its inputs, closed as ``u = -K y``.
    freq : array_like, optional
        Frequency grid (Hz) for the upper bound; default a coarse log grid around the closed-loop
        poles.  ``0`` Hz, the lower bound's crossing frequencies and a refinement around the peak are
        always added.
    eps : float
        Complex regularisation of the real parameters (conservatism about ``1 + eps``).
    n_directions : int
        Random directions tried by the lower-bound search (besides the box vertices).
    seed : int
        Random seed of the lower-bound search.
    progress : bool or None
        Progress bar over the frequencies of the upper bound; None (default) follows
        ``sdctrl.config.progress`` (shown only on a terminal or in a notebook).

    Returns
    -------
    RobustResult
    """
    Acl, Bcl, Ccl, Dcl = closed_loop_lft(um, controller)
    ev = np.linalg.eigvals(Acl)
    stable = bool(np.all(ev.real < 0))
    reps = [r for _, r in um.blocks]
    nb = len(reps)
    expand = np.zeros((sum(reps), nb))
    k = 0
    for i, r in enumerate(reps):
        expand[k:k + r, i] = 1
        k += r
    info = {}
    if not stable:
        warnings.warn("nominal closed loop is unstable: robust margin is 0")
        return RobustResult(0.0, 0.0, False, 0.0, np.zeros(nb), np.zeros(0), np.zeros(0), info)
    if nb == 0:
        return RobustResult(np.inf, np.inf, True, np.nan, np.zeros(0), np.zeros(0), np.zeros(0), info)
    # ---- lower bound: real destabilising perturbations
    rng = np.random.default_rng(seed)
    dirs = []
    if 2 ** nb <= 64:
        dirs = list(np.array(np.meshgrid(*[[-1.0, 1.0]] * nb, indexing="ij")).reshape(nb, -1).T)
    else:
        dirs = list(rng.choice([-1.0, 1.0], size=(64, nb)))
    dirs += list(rng.uniform(-1, 1, size=(n_directions, nb)))
    best_a, best_dir, cross = np.inf, np.zeros(nb), []
    amax = 10.0
    for d in dirs:
        d = d / np.max(np.abs(d))
        a, wc = _stab_along(Acl, Bcl, Ccl, Dcl, expand, d, min(amax, best_a))
        if np.isfinite(a):
            cross.append(wc)
            if a < best_a:
                best_a, best_dir = a, d * a
    # local refinement of the best direction (hill climbing on the direction, projected to the box)
    if np.isfinite(best_a) and nb > 1:
        step = 0.5
        for _ in range(3 * n_directions):
            d = best_dir / best_a + step * rng.normal(size=nb)
            d = np.clip(d, -1, 1)
            if not np.any(d):
                continue
            d = d / np.max(np.abs(d))
            a, wc = _stab_along(Acl, Bcl, Ccl, Dcl, expand, d, best_a, n_grid=20)
            if a < best_a:
                best_a, best_dir = a, d * a
                cross.append(wc)
            else:
                step *= 0.93
    # ---- upper bound over frequency
    if freq is None:
        wn = np.abs(ev)
        wn = wn[wn > 0]
        lo_w, hi_w = (wn.min() / 10, wn.max() * 10) if wn.size else (1e-2, 1e2)
        w = np.concatenate([[0.0], np.geomspace(lo_w, hi_w, 30), wn, np.abs(ev.imag)])
    else:
        w = 2 * np.pi * np.asarray(freq, float)
        w = np.concatenate([[0.0], w])
    w = np.unique(np.concatenate([w, np.asarray(cross, float)]))
    mu_lo = 1.0 / best_a if np.isfinite(best_a) else 0.0

    def eval_grid(ws, cur):
        Ms = _frf(Acl, Bcl, Ccl, Dcl, ws)
        # cheap upper bound: sqrt(1+eps^2)*||M|| (complex part) -- used to prune frequencies
        out = np.zeros(len(ws))
        cheap = np.array([np.linalg.norm(M, 2) for M in Ms]) * np.sqrt(1 + eps ** 2) * (1 + eps)
        order = np.argsort(-cheap)
        for i in progress_bar(order, desc="mu upper bound", unit="freq", enabled=progress):
            if cheap[i] <= cur:
                out[i] = cheap[i]
                continue
            out[i] = mu_upper(Ms[i], reps, eps=eps, lower=cur)[0]
            cur = max(cur, out[i])
        return out, cur
    mu, cur = eval_grid(w, mu_lo)
    # refine around the peak
    for _ in range(2):
        i = int(np.argmax(mu))
        a = w[max(i - 1, 0)]
        b = w[min(i + 1, len(w) - 1)]
        wr = np.linspace(a, b, 7)[1:-1]
        mr, cur = eval_grid(wr, cur)
        w = np.concatenate([w, wr])
        mu = np.concatenate([mu, mr])
        o = np.argsort(w)
        w, mu = w[o], mu[o]
    i = int(np.argmax(mu))
    mu_up = float(mu[i])
    margin = 1.0 / mu_up if mu_up > 0 else np.inf
    if mu_up < mu_lo * (1 - 1e-6):
        warnings.warn(f"mu upper bound {mu_up:.4g} below lower bound {mu_lo:.4g}: grid missed the "
                      "peak; margin set to the lower bound's")
        margin = best_a
    info.update(n_freq=len(w), mu_lower=mu_lo)
    return RobustResult(float(margin), float(best_a), stable, float(w[i] / (2 * np.pi)),
                        best_dir, w / (2 * np.pi), mu, info)


def worst_case_gain(um, controller, output: int = 0, input: int = 0, freq=None,
                    n_samples: int = 200, seed: int = 0, progress: bool | None = None) -> dict:
    """Worst-case closed-loop gain from a plant input disturbance to a plant output over Delta.

    The disturbance ``d`` is added to the plant input (``u = -K y + d``); the gain ``|y/d|`` is
    maximised over the box vertices and random samples of the normalised parameters.

    Parameters
    ----------
    um : UncertainModel
        Uncertain model.
    controller : control.StateSpace
        Controller closed as ``u = -K y``.
    output : int
        Plant output index.
    input : int
        Plant input index.
    freq : array_like, optional
        Frequencies (Hz); default a log grid around the model's modes.
    n_samples : int
        Random samples (besides vertices).
    seed : int
        Random seed.
    progress : bool or None
        Progress bar over the samples; None (default) follows ``sdctrl.config.progress``.

    Returns
    -------
    dict
        ``freq``, ``nominal`` gain, ``worst`` gain per frequency, ``peak``, ``worst_delta``.
    """
    import control

    nb = len(um.blocks)
    rng = np.random.default_rng(seed)
    if freq is None:
        f0 = np.asarray(um.model.frequency, float)
        f0 = f0[f0 > 0] if np.any(f0 > 0) else np.array([1.0])
        freq = np.geomspace(f0.min() / 5, f0.max() * 5, 400)
    w = 2 * np.pi * np.asarray(freq, float)
    verts = np.array(np.meshgrid(*[[-1.0, 1.0]] * nb, indexing="ij")).reshape(nb, -1).T \
        if 2 ** nb <= 256 else rng.choice([-1.0, 1.0], size=(256, nb))
    ds = np.vstack([np.zeros((1, nb)), verts, rng.uniform(-1, 1, (n_samples, nb))])
    worst = None
    peak, wd, nom = -np.inf, None, None
    for d in progress_bar(ds, desc="worst-case gain", unit="sample", enabled=progress):
        G = um.perturbed(d)
        cl = control.feedback(G, controller, sign=-1)
        H = np.abs(ss_frf(cl.A, cl.B, cl.C, cl.D, w)[:, output, input])
        if nom is None:
            nom = H
        worst = H if worst is None else np.maximum(worst, H)
        if H.max() > peak:
            peak, wd = H.max(), d
    return {"freq": np.asarray(freq, float), "nominal": nom, "worst": worst, "peak": float(peak),
            "worst_delta": wd}
