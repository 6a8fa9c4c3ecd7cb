"""Global candidate effects, fitted to the residual without an FE model.

- ``delay``: the measurement lags by ``tau``, ``H_I = H exp(-j w tau)`` (phase linear in
  frequency): ``tau`` from the weighted slope of the residual phase, then a bounded 1-D fit;
- ``residual_flexibility`` / ``residual_mass``: the out-of-band asymptotes (3.7)-(3.9),
  ``H + E`` and ``H + F / s^2`` with real ``E``, ``F``, for one actuator (location: its label)
  or all; with an FE model, the FE's own residual flexibility of the actuators with respect
  to the model's shapes (2.21), scaled by one factor;
- ``missing_mode`` (free): an extra normal mode ``c b^T / (s^2 + 2 zeta w s + w^2)`` (2.15),
  ``c`` and ``b`` real (its observability ``cphi`` at the data sensors and controllability
  ``phib`` at the data actuators, displacement per unit force: only ``c b^T`` is determined,
  the largest entry of ``phib`` being fixed by the fit); for given ``(w, zeta)`` the residue
  is the linear least-squares fit of the relative residual ``(H_d - H) / H_d`` (the logLS
  linearised about the data), made rank one in that fit's own metric
  (:mod:`._weighted_rank_one`: near-null channels of a symmetric structure kept near null);
  ``(w, zeta)`` are searched from the peaks of the residual;
- ``nonproportional_damping``: the coupling terms ``Gamma_ij`` (rad/s) between close modes
  that a diagonal (proportional) ``Gamma`` lacks (3.3, 5.1.1), by Gauss-Newton on the complex
  logLS residual.  The response is ``H = C Z(s)^-1 B`` (2.15), ``Z = s^2 I + s Gamma +
  Omega``, and with the transfers ``X_y = C Z^-1`` (ns, n) and ``X_u = Z^-1 B`` (n, na) its
  derivative is ``dH / dGamma_ij = -s C Z^-1 (e_i e_j^T + e_j e_i^T) Z^-1 B = -s (X_y,i X_u,j
  + X_y,j X_u,i)`` (the pair ``ij``/``ji`` is one parameter).

Each fit returns a *proposal*: a plain dict (kind, location, parameters, cost, number of
parameters ``k``, number of hypotheses ``m`` of its family, and what :mod:`.apply` needs).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from sdctrl.diagnosis._lowrank import Resolvent
from sdctrl.diagnosis._residual_map import complex_residual, cost
from sdctrl.diagnosis._weighted_rank_one import rank_one

__all__ = ["fit_delay", "fit_free_mode", "fit_nonproportional", "fit_residual_terms",
           "free_mode_region", "leaves_region", "ls_real", "proposal"]

#: damping ratios tried at each residual peak when searching an extra mode
ZETA_GRID = (0.001, 0.003, 0.01, 0.03)
#: sweeps of an extra mode's weighted rank-one residue (:mod:`._weighted_rank_one`) while its
#: frequency and damping are searched, and at the frequency and damping found
SEARCH_SWEEPS, FINAL_SWEEPS = 20, 500
#: residual peaks tried as the frequency of an extra mode
N_PEAKS = 3
#: modes closer than this many half-power bandwidths are coupled by non-proportional damping
COUPLING_BANDWIDTHS = 10.0
#: Gauss-Newton iterations of the non-proportional damping fit
GN_STEPS = 6
#: a free mode's region: frequency within these factors of the band's first and last lines
FREE_SPAN = (0.8, 1.2)
#: ... and damping ratio within these bounds; a mode fitted onto the region's edge (within
#: 2% of it) is a broadband trend, not a mode (never reported as one)
FREE_DAMPING = (1e-5, 0.5)


def free_mode_region(omega) -> tuple:
    """``(w_lo, w_hi, zeta_lo, zeta_hi)``: where a free extra mode is searched (rad/s).

    Parameters
    ----------
    omega : ndarray
        The band's lines (rad/s), increasing.

    Returns
    -------
    tuple of float
    """
    return (float(omega[0] * FREE_SPAN[0]), float(omega[-1] * FREE_SPAN[1])) + FREE_DAMPING


def leaves_region(prop, omega) -> bool:
    """Whether a proposal is a free mode fitted onto (or beyond) its region's edge.

    Parameters
    ----------
    prop : dict
        A proposal (any kind: only free modes can leave the region).
    omega : ndarray
        The band's lines (rad/s).

    Returns
    -------
    bool
    """
    if prop["action"] != "mode":
        return False
    lo, hi, _zlo, zhi = free_mode_region(omega)
    w, z = prop["payload"]["omega"], prop["payload"]["zeta"]
    return bool(z >= 0.98 * zhi or not lo * 1.02 < w < hi / 1.02)


def proposal(kind, location, parameters, cost_, k, m, action, payload) -> dict:
    """A fitted candidate effect (plain data, picklable).

    Parameters
    ----------
    kind : str
        One of the eight effect kinds.
    location : object
        What it applies to (labels, a frequency) or None.
    parameters : dict
        Fitted sizes (SI units).
    cost_ : float
        Cost with the effect.
    k : int
        Number of fitted parameters.
    m : int
        Number of hypotheses of its family.
    action : str
        How :mod:`sdctrl.diagnosis._apply` applies it.
    payload : dict
        What it needs.

    Returns
    -------
    dict
    """
    return {"kind": kind, "location": location, "parameters": dict(parameters),
            "cost": float(cost_), "k": int(k), "m": int(max(m, 1)), "action": action,
            "payload": payload}


def fit_delay(placed, H) -> dict:
    """A measurement delay ``exp(-j w tau)`` on every channel.

    Parameters
    ----------
    placed : Placed
        The data.
    H : ndarray, shape (nf, ns, na)
        Current prediction.

    Returns
    -------
    dict
        Proposal; ``parameters = {"tau": seconds}``.
    """
    w = placed.omega
    r = complex_residual(H, placed.Hd)
    # data = H exp(-j w tau): Im Log(H / Hd) = w tau; weighted slope, robust to outliers
    ph = r.imag
    wt = 1.0 / (1.0 + (r.real / 0.1) ** 2)
    tau0 = float(np.sum(wt * w[:, None, None] * ph) / max(np.sum(wt * w[:, None, None] ** 2),
                                                             1e-300))
    span = max(abs(tau0), 0.05 / w.max())

    def J(t):
        return cost(H * np.exp(-1j * w * t)[:, None, None], placed.Hd)

    res = minimize_scalar(J, bounds=(tau0 - span, tau0 + span), method="bounded",
                          options={"xatol": 1e-6 * span})
    tau = float(res.x) if res.fun < J(tau0) else tau0
    return proposal("delay", None, {"tau": tau}, J(tau), 1, 1, "delay", {"tau": tau})


def ls_real(A, e):
    """Per-channel real least squares ``min sum_l |e_l - x a_l|^2``.

    Parameters
    ----------
    A, e : ndarray, shape (nf, ns, na)
        Regressor and data per line and channel.

    Returns
    -------
    ndarray, shape (ns, na)
    """
    den = np.sum(np.abs(A) ** 2, axis=0)
    return np.where(den > 0, np.sum((np.conj(A) * e).real, axis=0) / np.maximum(den, 1e-300),
                    0.0)


def fit_residual_terms(placed, H, fe_flex=None) -> list[dict]:
    """Residual flexibility (``+E``) and residual mass (``+F/s^2``) terms.

    Parameters
    ----------
    placed : Placed
        The data.
    H : ndarray, shape (nf, ns, na)
        Current prediction (displacement/force).
    fe_flex : ndarray, shape (ns, na), optional
        The FE's residual flexibility of the actuators at the sensors (w.r.t. the model's
        shapes); adds one-factor hypotheses per actuator.

    Returns
    -------
    list of dict
    """
    s = placed.s
    e = (placed.Hd - H) / H
    out = []
    na = H.shape[2]
    shapes = {"residual_flexibility": np.ones_like(s), "residual_mass": 1.0 / s**2}
    for kind, phi in shapes.items():
        A = phi[:, None, None] / H
        X = ls_real(A, e)                                     # (ns, na)
        key = "E" if kind == "residual_flexibility" else "F"
        cands = [(None, X)] + [(placed.actuators[j], X * (np.arange(na) == j)) for j in
                               range(na)] if na > 1 else [(None, X)]
        for loc, Xc in cands:
            k = int(np.count_nonzero(np.any(Xc != 0, axis=1))) * (na if loc is None else 1)
            J = cost(H + phi[:, None, None] * Xc, placed.Hd)
            out.append(proposal(kind, loc, {key: Xc.copy()}, J, max(k, 1), 1 + na,
                                "residual", {"field": key, "X": Xc}))
    if fe_flex is not None and np.any(fe_flex):
        for j in range(na):
            g = fe_flex[:, j]
            if not np.any(g):
                continue
            a = (g[None, :] / H[:, :, j])
            alpha = float(np.sum((np.conj(a) * e[:, :, j]).real) / np.sum(np.abs(a) ** 2))
            Xc = np.zeros_like(fe_flex)
            Xc[:, j] = alpha * g
            J = cost(H + Xc[None], placed.Hd)
            out.append(proposal("residual_flexibility", placed.actuators[j],
                                {"E": Xc.copy(), "scale": alpha}, J, 1, na, "residual",
                                {"field": "E", "X": Xc}))
    return out


def _mode_residue(placed, e, w, z, sweeps=SEARCH_SWEEPS):
    """Rank-one real residue of an extra mode at ``(w, zeta)``: (X, proxy cost).  ``e = (H_d
    - H) / H_d``: the complex logLS residual (3.12) linearised about the data (bounded where
    the model without the mode has an antiresonance the data lack, unlike ``/ H``);
    ``sweeps`` of the weighted rank-one fit (few while ``(w, zeta)`` are searched)."""
    s = placed.s
    phi = 1.0 / (s**2 + 2 * z * w * s + w**2)
    A = phi[:, None, None] / placed.Hd
    X = ls_real(A, e)
    X1 = rank_one(X, np.sum(np.abs(A) ** 2, axis=0), float(np.sum(np.abs(e - A * X) ** 2)),
                  sweeps)
    return X1, float(np.mean(np.abs(e - A * X1) ** 2)), phi


def _peaks(per_line, n):
    """Indices of the ``n`` largest local maxima (a line per peak)."""
    e = per_line
    loc = np.flatnonzero(np.r_[e[0] > e[1], (e[1:-1] >= e[:-2]) & (e[1:-1] >= e[2:]),
                               e[-1] > e[-2]]) if e.size > 2 else np.arange(e.size)
    return loc[np.argsort(e[loc])[::-1][:n]]


def fit_free_mode(placed, H) -> dict | None:
    """An extra normal mode with a free real rank-one residue.

    Parameters
    ----------
    placed : Placed
        The data.
    H : ndarray, shape (nf, ns, na)
        Current prediction.

    Returns
    -------
    dict or None
        Proposal with ``parameters = {"frequency": Hz, "damping": ratio, "cphi": (ns,),
        "phib": (na,)}`` (module notes); location the frequency (Hz).
    """
    w = placed.omega
    if w.size < 5:
        return None
    e = (placed.Hd - H) / placed.Hd
    r = complex_residual(H, placed.Hd)
    per_line = np.mean(np.abs(r) ** 2, axis=(1, 2))
    best = None
    for i in _peaks(per_line, N_PEAKS):
        for z in ZETA_GRID:
            _, c, _ = _mode_residue(placed, e, w[i], z)
            if best is None or c < best[0]:
                best = (c, w[i], z)
    lo, hi, zlo, zhi = free_mode_region(w)

    def proxy(x):
        wx, zx = np.exp(x[0]), np.exp(x[1])
        if not (lo < wx < hi and zlo < zx < zhi):
            return np.inf
        return _mode_residue(placed, e, wx, zx)[1]

    res = minimize(proxy, [np.log(best[1]), np.log(best[2])], method="Nelder-Mead",
                   options={"xatol": 1e-6, "fatol": 1e-12 * max(best[0], 1e-300),
                            "maxfev": 300})
    wm, zm = np.exp(res.x)
    X1, _, phi = _mode_residue(placed, e, wm, zm, FINAL_SWEEPS)
    if not np.all(np.isfinite(X1)):          # no finite mode there (e.g. lines ~ 1e300 Hz)
        return None
    U, S, Vt = np.linalg.svd(X1)
    c, b = U[:, 0] * np.sqrt(S[0]), Vt[0] * np.sqrt(S[0])
    J = cost(H + phi[:, None, None] * np.outer(c, b)[None], placed.Hd)
    for window in (True, False):     # near the mode; then its residue on every line
        wr, zr, cr, br = _refine_mode(placed, H, wm, zm, c, b, (lo, hi), window=window,
                                      pole=window)
        phr = 1.0 / (placed.s**2 + 2 * zr * wr * placed.s + np.square(wr))  # inf, not an error
        Jr = cost(H + phr[:, None, None] * np.outer(cr, br)[None], placed.Hd)
        if Jr < J:
            wm, zm, c, b, J = wr, zr, cr, br, Jr
    ns, na = X1.shape
    fr = float(wm / (2 * np.pi))
    out = proposal("missing_mode", fr, {"frequency": fr, "damping": float(zm), "cphi": c.copy(),
                                        "phib": b.copy()}, J,
                   2 + ns + na - 1, w.size, "mode",
                   {"omega": float(wm), "zeta": float(zm), "c": c, "b": b})
    return None if leaves_region(out, w) else out      # a broadband trend (never invented)


def _mode_normal(s, w, z, c, b, phi, Hm, r):
    """Gauss-Newton normal equations ``(Re J^H J, Re J^H r)`` of ``r = Log(H + phi c b^T) -
    Log H_d`` in ``(log w, log zeta, c, b)``, built from its blocks (the ``c`` and ``b``
    columns of ``J`` are sparse: ``P b_a`` on sensor ``s``, ``P c_s`` on actuator ``a``, with
    ``P = phi / H``), never forming ``J``."""
    ns, na = c.size, b.size
    Q = 1.0 / Hm
    P = phi[:, None, None] * Q
    cb = np.outer(c, b)
    Ju = (-phi**2 * (2 * z * s + 2 * w) * w)[:, None, None] * cb * Q
    Jv = (-phi**2 * (2 * w * s) * z)[:, None, None] * cb * Q
    P2 = (P.real**2 + P.imag**2).sum(axis=0)                                # (ns, na)
    A = np.zeros((2 + ns + na, 2 + ns + na))
    g = np.zeros(2 + ns + na)
    for i, Jx in enumerate((Ju, Jv)):
        for k, Jy in enumerate((Ju, Jv)):
            A[i, k] = np.sum((np.conj(Jx) * Jy).real)
        X = (np.conj(Jx) * P).real.sum(axis=0)                              # (ns, na)
        A[i, 2:2 + ns] = A[2:2 + ns, i] = X @ b
        A[i, 2 + ns:] = A[2 + ns:, i] = c @ X
        g[i] = np.sum((np.conj(Jx) * r).real)
    A[2:2 + ns, 2:2 + ns] = np.diag(P2 @ b**2)
    A[2 + ns:, 2 + ns:] = np.diag(c**2 @ P2)
    A[2:2 + ns, 2 + ns:] = P2 * cb
    A[2 + ns:, 2:2 + ns] = (P2 * cb).T
    Y = (np.conj(P) * r).real.sum(axis=0)                                   # (ns, na)
    g[2:2 + ns] = Y @ b
    g[2 + ns:] = c @ Y
    return A, g


def _refine_mode(placed, H, w, z, c, b, wlim, steps=15, window=True, pole=True):
    """Levenberg-Marquardt on the complex logLS of an extra mode, on the lines around it
    (the linearised fit of :func:`_mode_residue` is poor where the mode is entirely missing,
    the residual there being large), or on every line (``window=False``: its tails, which
    matter at the antiresonances far from it -- the truss's missing 12.66 Hz mode fitted on
    its window left 1.41e-4 at 1% noise, from its tail at 32 Hz; its residue then refitted on
    every line, 1.0e-4).  ``pole=False`` keeps the frequency and damping (the window's):
    on every line a mode that stands for a change of the host as well (a resonator loading
    it) would otherwise move off its own peak to follow the host's shifts."""
    om = placed.omega
    win = np.abs(om - w) <= max(0.1 * w, 30 * z * w)
    if np.count_nonzero(win) < 5 or not window:
        win = np.ones(om.size, bool)
    s, H_, Hd = placed.s[win], H[win], placed.Hd[win]
    ns = c.size

    def model(x):
        wx, zx = np.exp(x[0]), np.exp(x[1])
        phi = 1.0 / (s**2 + 2 * zx * wx * s + wx**2)
        Hm = H_ + phi[:, None, None] * np.outer(x[2:2 + ns], x[2 + ns:])[None]
        return wx, zx, phi, Hm

    x = np.r_[np.log(w), np.log(z), c, b]
    lb = np.r_[np.log(wlim[0]), np.log(FREE_DAMPING[0])]
    ub = np.r_[np.log(wlim[1]), np.log(FREE_DAMPING[1])]
    wx, zx, phi, Hm = model(x)
    J, mu = cost(Hm, Hd), 1e-3
    for _ in range(steps):
        r = complex_residual(Hm, Hd)
        A, g = _mode_normal(s, wx, zx, x[2:2 + ns], x[2 + ns:], phi, Hm, r)
        if not pole:
            A[:2], A[:, :2], g[:2] = 0.0, 0.0, 0.0
            A[0, 0] = A[1, 1] = 1.0
        d = np.diag(A) + 1e-12 * max(np.trace(A), 1e-300)
        for _try in range(6):
            xt = x - np.linalg.solve(A + mu * np.diag(d), g)
            xt[:2] = np.clip(xt[:2], lb, ub)
            t = model(xt)
            Jt = cost(t[3], Hd)
            if Jt < J:
                break
            mu *= 10.0
        else:
            break
        done = Jt > (1 - 1e-6) * J
        x, (wx, zx, phi, Hm), J, mu = xt, t, Jt, max(mu / 10.0, 1e-9)
        if done:
            break
    return float(np.exp(x[0])), float(np.exp(x[1])), x[2:2 + ns].copy(), x[2 + ns:].copy()


def _coupled_pairs(Omega, Gamma, fmin, fmax):
    """Mode pairs (i < j), both in the band, closer than COUPLING_BANDWIDTHS half-power
    bandwidths ``Gamma_jj`` (the pairs that damping coupling can mix; static correction
    modes far above the band, heavily damped, are left out)."""
    w = np.sqrt(np.clip(np.diag(Omega), 0, None))
    g = np.maximum(np.abs(np.diag(Gamma)), 1e-4 * w)
    inb = (w >= 2 * np.pi * fmin * 0.95) & (w <= 2 * np.pi * fmax * 1.05) & (w > 0)
    out = []
    for i in range(w.size):
        for j in range(i + 1, w.size):
            if inb[i] and inb[j] and w[i] > 0 and w[j] > 0 and \
                    abs(w[i] - w[j]) <= COUPLING_BANDWIDTHS * max(g[i], g[j]):
                out.append((i, j))
    return out


def fit_nonproportional(placed, model, rows, cols, H=None) -> dict | None:
    """Coupling terms ``Gamma_ij`` between close modes, by Gauss-Newton on the complex logLS.

    The model's response on the data channels is ``C Z(s)^-1 B + H_rest`` (2.15), ``Z(s) =
    s^2 I + s Gamma + Omega``; ``H_rest`` (the ``E + F / s^2`` terms and any residual
    dynamics) does not depend on ``Gamma`` and is kept as it is in the model's response.
    Each step solves the normal equations of the linearised logLS (3.12) with ``dH /
    dGamma_ij = -s (X_y,i X_u,j + X_y,j X_u,i)`` (module notes), halving the step until the
    cost decreases.

    Parameters
    ----------
    placed : Placed
        The data.
    model : NormalModeModel
        Current model.
    rows, cols : ndarray of int
        Model sensors/actuators of the data channels.
    H : ndarray, shape (nf, ns, na), optional
        The model's displacement response on ``placed`` (computed when not given).

    Returns
    -------
    dict or None
        Proposal with ``parameters = {"Gamma_i_j": rad/s}`` (1-based mode numbers, the
        change of the model's ``Gamma_ij``), ``k`` the number of pairs; None when the model
        has no close pair in the band (or a coupled ``Omega``).
    """
    if np.count_nonzero(model.Omega - np.diag(np.diag(model.Omega))):
        return None
    pairs = _coupled_pairs(model.Omega, model.Gamma, placed.freq[0], placed.freq[-1])
    if not pairs:
        return None
    s, Hd = placed.s, placed.Hd
    Omega, Gamma0 = np.asarray(model.Omega, float), np.asarray(model.Gamma, float)
    C, B = np.asarray(model.cphi)[rows], np.asarray(model.phib)[:, cols]
    eye = np.eye(model.n)
    H0 = placed.response(model) if H is None else H
    rest = H0 - Resolvent.of(Omega, Gamma0).transfer(s, C.T, B)   # E + F/s^2 + residual

    def response(G):
        R = Resolvent.of(Omega, G)
        Xy = R.transfer(s, C.T, eye)                          # C Z^-1, (nf, ns, n)
        Xu = R.transfer(s, eye, B)                            # Z^-1 B, (nf, n, na)
        return Xy @ B + rest, Xy, Xu

    I, K = (np.array(v) for v in zip(*pairs))
    x, G = np.zeros(len(pairs)), Gamma0.copy()
    Hc, Xy, Xu = response(G)
    J0 = J = cost(Hc, Hd)
    for it in range(GN_STEPS):
        step = _gamma_step(s, Hc, Hd, Xy, Xu, I, K)
        for _half in range(8):
            Gt = _with_pairs(Gamma0, I, K, x + step)
            Ht, Xyt, Xut = response(Gt)
            Jt = cost(Ht, Hd)
            if Jt < J:
                break
            step = 0.5 * step
        else:
            break
        done = Jt > (1 - 1e-9) * J
        x, G, Hc, Xy, Xu, J = x + step, Gt, Ht, Xyt, Xut, Jt
        if done or (it == 0 and J > (1 - 1e-4) * J0):
            break
    params = {f"Gamma_{i + 1}_{j + 1}": float(v) for (i, j), v in zip(pairs, x)}
    return proposal("nonproportional_damping", None, params, J, len(pairs), 1, "gamma",
                    {"dGamma": G - Gamma0})


def _with_pairs(Gamma0, I, K, x):
    """``Gamma0`` with ``x`` added to the symmetric pairs ``(I, K)``."""
    G = Gamma0.copy()
    G[I, K] += x
    G[K, I] += x
    return G


def _gamma_step(s, H, Hd, Xy, Xu, I, K):
    """Gauss-Newton step of the coupling terms: the normal equations of the linearised
    complex logLS, ``d Log H / dGamma_ij = dH / dGamma_ij / H`` for every pair at once."""
    r = complex_residual(H, Hd).reshape(-1)
    sH = (-s[:, None, None] / H)[..., None]
    Jm = (np.einsum("fsp,fpa->fsap", Xy[:, :, I], Xu[:, K, :])
          + np.einsum("fsp,fpa->fsap", Xy[:, :, K], Xu[:, I, :])) * sH
    Jm = Jm.reshape(-1, I.size)
    # the Jacobian is tall (lines x channels) and narrow (pairs)
    JtJ = (Jm.conj().T @ Jm).real
    JtJ += 1e-12 * np.trace(JtJ) / JtJ.shape[0] * np.eye(JtJ.shape[0])
    return np.linalg.lstsq(JtJ, -(Jm.conj().T @ r).real, rcond=None)[0]
