"""The D-G scaling LMI of the mixed mu upper bound, solved by an interior-point method.

For a fixed ``beta`` the condition (1) of :mod:`sdctrl.robust.mu._upper`,

    M^H D M + j (G M - M^H G) - beta^2 D <= 0,    D >= I,    (D, G) commuting with Delta,

is a linear matrix inequality in the scalings (Fan, Tits and Doyle 1991); the smallest feasible
``beta`` (bisection) is the optimal D-G bound that the BFGS search of
:func:`sdctrl.robust.mu._upper.dg_upper` approaches from above.  The problem is written once per
matrix with the block structure as block-diagonal variables (a Hermitian ``D_k`` and ``G_k`` per
repeated scalar, ``d_k I`` per full block) and ``beta^2`` as a cvxpy parameter, so the bisection
re-solves without recompiling.

The solver's answer is never returned as a bound: its scalings are certified by the exact
generalised eigenvalue (:func:`certify_dg`), so whatever the solver's accuracy, every value
returned is a valid upper bound of mu.  Its cost grows fast with the number of channels (an
``N x N`` complex semidefinite constraint): it is meant for small problems (tens of channels),
to polish a bound at one frequency and as the reference of the tests.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from sdctrl.robust.mu._structure import BlockStructure

__all__ = ["LMIBound", "certify_dg", "lmi_bound"]


def certify_dg(M, D, G) -> float:
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


@dataclass(frozen=True, eq=False)
class LMIBound:
    """Outcome of :func:`lmi_bound`.

    Parameters
    ----------
    bound : float
        Certified upper bound of the best scalings found (``inf`` if none).
    D, G : ndarray or None
        Those scalings.
    lower : float
        Largest ``beta`` the solver declared infeasible: the LMI optimum lies in
        ``[lower, bound]`` as far as the solver's infeasibility claims are right (not a
        certificate of mu).
    solves : int
        Number of semidefinite programs solved.
    failed : bool
        The solver failed (error or unknown status) and the bisection stopped there.
    """

    bound: float
    D: np.ndarray | None
    G: np.ndarray | None
    lower: float
    solves: int
    failed: bool


#: dynamic range of the scalings searched by the LMI (``I <= D <= D_MAX I``): wider ranges make
#: Clarabel fail near the optimum (measured: no failure at 1e3, 7 of 10 small cases at 1e4);
#: :func:`sdctrl.robust.mu._upper.dg_upper` centres the range on its BFGS scalings when it polishes
D_MAX = 1e3


def _problem(M, st: BlockStructure):
    """The LMI of ``M`` with ``beta^2`` as a parameter, as the smallest ``t`` with
    ``lhs(beta) <= t I`` over bounded scalings (always strictly feasible, which interior-point
    solvers handle far better than a bare feasibility problem near its boundary): ``beta`` is
    certified when ``t < 0``.  Returns ``(problem, beta2, t, D, G)``."""
    import cvxpy as cp

    n = len(st.sizes)
    Ds, Gs, cons = [], [], []
    for r, kind in zip(st.sizes, st.kinds):
        if kind == "full" or r == 1:
            d = cp.Variable()
            Ds.append(d * np.eye(r) if r > 1 else cp.reshape(d, (1, 1), order="C"))
            cons.append(d >= 1)
        else:
            Dk = cp.Variable((r, r), hermitian=True)
            Ds.append(Dk)
            cons.append(Dk >> np.eye(r))
        if kind != "real":
            Gs.append(np.zeros((r, r)))
        elif r == 1:
            Gs.append(cp.reshape(cp.Variable(), (1, 1), order="C"))
        else:
            Gs.append(cp.Variable((r, r), hermitian=True))

    def diag(blocks):
        return cp.bmat([[blocks[i] if i == j else np.zeros((st.sizes[i], st.sizes[j]))
                         for j in range(n)] for i in range(n)])

    D, G = diag(Ds), diag(Gs)
    beta2 = cp.Parameter(nonneg=True)
    t = cp.Variable()
    lhs = M.conj().T @ D @ M + 1j * (G @ M - M.conj().T @ G) - beta2 * D
    cons += [0.5 * (lhs + lhs.H) << t * np.eye(st.N), D << D_MAX * np.eye(st.N)]
    return cp.Problem(cp.Minimize(t), cons), beta2, t, D, G


def lmi_bound(M, st: BlockStructure, hi: float | None = None, lo: float = 0.0,
              rtol: float = 1e-5, D0=None, rounds: int = 3, max_solves: int = 40,
              solver: str = "CLARABEL") -> LMIBound:
    """Optimal D-G bound of ``M`` by bisection on ``beta`` over the LMI (1), certified.

    The LMI searches ``I <= Dh <= D_MAX I`` for ``Mh = F^H M F^-H`` (``F F^H = D0``, the
    centre), which is the LMI of ``M`` for ``D = F Dh F^H``, ``G = F Gh F^H``; each further
    round re-centres on the best scalings so far, until a round gains less than ``rtol`` (the
    range then no longer binds near the optimum).

    Parameters
    ----------
    M : ndarray (N, N)
        Complex matrix.
    st : BlockStructure
        Uncertainty structure (``st.N == N``).
    hi : float, optional
        A known upper bound (e.g. the BFGS bound; default ``1.01 ||M||``).
    lo : float
        Start of the first bisection from below.
    rtol : float
        Relative width of the final bracket.
    D0 : ndarray (N, N), optional
        Centre of the first round (e.g. the BFGS ``D``); default the identity.
    rounds : int
        Most rounds.
    max_solves : int
        Most semidefinite programs solved per round.
    solver : str
        cvxpy solver (an interior-point SDP solver).

    Returns
    -------
    LMIBound
    """
    M = np.asarray(M, complex)
    hi = 1.01 * float(np.linalg.norm(M, 2)) if hi is None else float(hi)
    if hi == 0.0:
        return LMIBound(0.0, np.eye(st.N), np.zeros((st.N, st.N)), 0.0, 0, False)
    best, D0 = (np.inf, None, None), np.eye(st.N) if D0 is None else np.asarray(D0, complex)
    lower, solves = lo, 0
    for _ in range(max(int(rounds), 1)):
        F = np.linalg.cholesky(0.5 * (D0 + D0.conj().T))
        Mh = F.conj().T @ np.linalg.solve(F, M.conj().T).conj().T           # F^H M F^-H
        got, lower, n, failed = _bisect(Mh, st, min(hi, best[0]), lo if best[1] is None
                                        else 0.0, rtol, max_solves, solver)
        solves += n
        gain = got[1] is not None and got[0] < best[0] * (1 - rtol)
        if got[1] is not None:
            D, G = F @ got[1] @ F.conj().T, F @ got[2] @ F.conj().T
            c = certify_dg(M, D, G)                   # exact, whatever the solver's accuracy
            if c < best[0]:
                best, D0 = (c, D, G), D
        if failed or not gain:
            break
    return LMIBound(*best, lower, solves, failed)


def _bisect(M, st, hi, lo, rtol, max_solves, solver):
    """Bisection of one round: ``((bound, D, G), lower, solves, failed)`` for ``M``."""
    import cvxpy as cp

    s = float(np.linalg.norm(M, 2))
    prob, beta2, tv, Dv, Gv = _problem(M / s, st)       # scaled: beta / s in [0, ~1]
    hi, lo = hi / s, lo / s
    best, solves, failed = (np.inf, None, None), 0, False
    while hi - lo > rtol * hi and solves < max_solves:
        mid = 0.5 * (lo + hi)
        beta2.value = mid ** 2
        solves += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")          # "solution may be inaccurate"
                prob.solve(solver=solver)
            status = prob.status
        except cp.error.SolverError:
            status = "error"
        if status in ("optimal", "optimal_inaccurate") and tv.value < 0:
            D, G = np.asarray(Dv.value, complex), s * np.asarray(Gv.value, complex)
            try:
                c = certify_dg(M, D, G)
            except (np.linalg.LinAlgError, ValueError):
                c = np.inf
            if c < best[0]:
                best = (c, D, G)
            hi = mid
        elif status in ("optimal", "optimal_inaccurate"):
            lo = mid
        else:
            failed = True
            break
    return best, lo * s, solves, failed
