"""Standard deviations of normal-mode parameters propagated from the identification (3.4).

:func:`~sdctrl.normal_modes` maps the identified poles and residues to ``Omega``, ``Gamma``,
``cphi``, ``phib`` through the scaling (3.24), the properness correction (3.51)-(3.52) and
the exact transformation (3.44).  To first order a change ``dx`` of the identified
parameters ``x = [theta; C_1 ... C_m]`` (poles' real and imaginary parts, each channel's
basis coefficients, :mod:`~sdctrl.identification._pole_statistics`) changes the
normal-mode parameters by ``T dx``; ``T`` is evaluated column by column by finite
differences of the transformation itself (a step of a hundredth of each parameter's own
standard deviation), mode signs aligned with the nominal model.  The covariance of ``x``
is used in its block form, never assembled:

``diag(T Cov T^T) = diag(G S G^T + 2 Y A^-1 G^T + sum_c T_c V_c T_c^T)``

with ``Z = sum_c T_c M_c``, ``Y = sum_c T_c K_c`` and ``G = T_theta - Z``.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl.identification._pole_statistics import coefficient_variance
from sdctrl.identification._residues import coefficients_to_model

__all__ = ["with_std"]

#: finite-difference step as a fraction of each parameter's standard deviation
STEP = 1e-2
#: above this many Jacobian columns the direct part of the residues' variance is sampled
MAX_COLUMNS = 200
#: draws of the sampled direct part (standard deviations to about 9%)
SAMPLES = 64


def with_std(nm, cm, transform):
    """``nm`` with :attr:`NormalModeModel.std` propagated from ``cm.statistics``.

    Parameters
    ----------
    nm : NormalModeModel
        The normal-mode model of ``cm`` (nominal).
    cm : ComplexModeModel
        The identified model; without statistics ``nm`` is returned unchanged.
    transform : callable
        ``ComplexModeModel -> NormalModeModel``, the transformation that gave ``nm`` (same
        modes and options).

    Returns
    -------
    NormalModeModel
    """
    stats = cm.statistics
    if stats is None:
        return nm
    C0 = _coefficients(cm, stats)
    rows = stats.n * (2 if stats.model == "complex" else 1)    # E, F: carried over unchanged
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if 2 * stats.n + rows * C0.shape[1] <= MAX_COLUMNS:
                var = _exact_variance(cm, stats, C0, nm, transform)
            else:
                var = _sampled_variance(cm, stats, C0, nm, transform)
        except (ValueError, np.linalg.LinAlgError):
            var = np.full(_size(nm), np.nan)
    std = np.sqrt(np.maximum(var, 0.0))
    std[~np.isfinite(var)] = np.nan
    return nm.replace(std=_split(std, nm))


def _exact_variance(cm, stats, C0, nm, transform):
    """Variance of the outputs from the full finite-difference Jacobian (module notes)."""
    T_theta, T = _jacobian(cm, stats, C0, nm, transform)
    Z = np.einsum("moq,mqa->oa", T, stats.M)
    Y = np.einsum("moq,mqa->oa", T, stats.K)
    G = T_theta - Z
    return (np.einsum("oa,ab,ob->o", G, stats.S, G)
            + 2 * np.einsum("oa,ab,ob->o", Y, stats.A_inv, G)
            + np.einsum("moq,mqr,mor->o", T, stats.V, T, optimize=True))


def _sampled_variance(cm, stats, C0, nm, transform, n_samples=None, seed=0):
    """Variance of the outputs with the parts through the poles exact and the direct part
    of the residues sampled (module notes).

    ``G S G^T + 2 Y A^-1 G^T`` needs ``T_theta`` (one difference per pole coordinate) and
    ``Z = T M``, ``Y = T K`` (one directional difference per pole coordinate each);
    ``sum_c T_c V_c T_c^T`` is the mean of ``(T u)^2`` over draws ``u_c ~ N(0, V_c)``
    (relative error of the standard deviation about ``1 / sqrt(2 n_samples)``).
    """
    n_samples = n_samples or SAMPLES
    rng = np.random.default_rng(seed)
    m, q, n2 = stats.M.shape
    theta0 = np.stack([cm.poles.real, cm.poles.imag], axis=1).ravel()
    y0 = _outputs(nm, nm)
    sd_C = float(np.sqrt(np.mean(np.einsum("mpp->mp", stats.V)))) or 1e-300

    def slope(dtheta, dC, size):
        return _difference(lambda h: _outputs(transform(_model(
            cm, stats, theta0 + h * dtheta, C0 + h * dC)), nm), y0, STEP * size)

    T_theta, Z, Y = (np.zeros((y0.size, n2)) for _ in range(3))
    zero_t, zero_c = np.zeros(n2), np.zeros_like(C0)
    for a in range(n2):
        e = np.zeros(n2)
        e[a] = 1.0
        size = np.sqrt(stats.S[a, a]) or 1e-9 * np.abs(theta0).max()
        if a % 2 == 0 and theta0[a] + STEP * size >= 0:  # a pole at the damping floor
            size = -size                                 # stays stable (as in _jacobian)
        T_theta[:, a] = slope(e, zero_c, size)
        for out, blk in ((Z, stats.M), (Y, stats.K)):
            d = blk[:, :, a].T                                          # (q, m)
            norm = float(np.sqrt(np.mean(d**2)))
            out[:, a] = slope(zero_t, d, sd_C / norm) if norm > 0 else 0.0
    G = T_theta - Z
    var = (np.einsum("oa,ab,ob->o", G, stats.S, G)
           + 2 * np.einsum("oa,ab,ob->o", Y, stats.A_inv, G))
    V = stats.V + 1e-12 * np.trace(stats.V, axis1=1, axis2=2)[:, None, None] * np.eye(q)
    L = np.linalg.cholesky(V)
    acc = np.zeros(y0.size)
    for _ in range(n_samples):
        u = np.einsum("mqr,mr->qm", L, rng.standard_normal((m, q)))
        acc += slope(zero_t, u, 1.0) ** 2
    return var + acc / n_samples


def _coefficients(cm, stats):
    """The basis coefficients ``C`` (q, m) of ``cm`` (inverse of ``coefficients_to_model``)."""
    n, m = cm.n, cm.ns * cm.na
    R = np.asarray(cm.residues).reshape(n, m)
    rows = []
    if stats.model == "complex":
        rows.append(np.stack([R.real, R.imag], axis=1).reshape(2 * n, m))
    else:
        rows.append((R * (cm.poles - cm.poles.conj())[:, None]).real)
    if stats.asymptotic[0]:
        rows.append(np.asarray(cm.E).reshape(1, m))
    if stats.asymptotic[1]:
        rows.append(np.asarray(cm.F).reshape(1, m))
    return np.vstack(rows)


def _model(cm, stats, theta, C):
    """``cm`` with poles ``theta`` (2n,) and coefficients ``C`` (q, m), no statistics."""
    lam = theta[0::2] + 1j * theta[1::2]
    R, E, F = coefficients_to_model(C, lam, stats.model, stats.asymptotic, cm.ns, cm.na)
    return cm.replace(poles=lam, residues=R, E=E if stats.asymptotic[0] else cm.E,
                      F=F if stats.asymptotic[1] else cm.F, statistics=None)


def _outputs(nm, ref):
    """``[Omega, Gamma, cphi, phib]`` flattened, mode signs aligned with ``ref``."""
    if nm.n != ref.n or nm.ns != ref.ns or nm.na != ref.na:
        raise ValueError("the perturbed transformation changed the number of modes")
    d = np.sign(np.sum(nm.cphi * ref.cphi, axis=0) + np.sum(nm.phib * ref.phib, axis=1))
    d[d == 0] = 1.0
    return np.concatenate([np.asarray(nm.Omega).ravel(), (d[:, None] * nm.Gamma * d).ravel(),
                           (nm.cphi * d).ravel(), (d[:, None] * nm.phib).ravel()])


def _jacobian(cm, stats, C0, nm, transform):
    """Finite-difference Jacobians ``T_theta`` (out, 2n) and ``T`` (m, out, q)."""
    theta0 = np.stack([cm.poles.real, cm.poles.imag], axis=1).ravel()
    y0 = _outputs(nm, nm)
    sd_theta = np.sqrt(np.maximum(np.diag(stats.S), 0.0))
    # steps from the coefficients' std; those of undetermined (out-of-band) poles are NaN:
    # their step falls back to the coefficient's scale
    sd_C = np.sqrt(np.nan_to_num(coefficient_variance(stats), nan=0.0))   # (q, m)
    T_theta = np.zeros((y0.size, theta0.size))
    for a in range(theta0.size):
        h = STEP * sd_theta[a] or 1e-9 * max(np.abs(theta0).max(), 1e-300)
        if a % 2 == 0 and theta0[a] + h >= 0:    # a pole at the damping floor stays stable
            h = -h
        e = np.zeros(theta0.size)
        e[a] = 1.0
        T_theta[:, a] = _difference(lambda x: _outputs(transform(_model(
            cm, stats, theta0 + x * e, C0)), nm), y0, h)
    q, m = C0.shape
    T = np.zeros((m, y0.size, q))
    scale = np.abs(C0).max(axis=1)
    rows = stats.n * (2 if stats.model == "complex" else 1)
    for c in range(m):
        for p in range(rows):
            h = STEP * sd_C[p, c] or 1e-9 * max(scale[p], 1e-300)
            E = np.zeros_like(C0)
            E[p, c] = 1.0
            T[c, :, p] = _difference(lambda x: _outputs(transform(_model(
                cm, stats, theta0, C0 + x * E)), nm), y0, h)
    return T_theta, T


def _difference(f, y0, h):
    """``(f(h) - y0) / h``; where the perturbed model cannot be transformed (properness
    lost on one side of a nominal near its limit, 3.52) the step is taken the other way."""
    try:
        return (f(h) - y0) / h
    except ValueError:
        return (f(-h) - y0) / -h


def _size(nm):
    return 2 * nm.n**2 + nm.ns * nm.n + nm.n * nm.na


def _split(v, nm):
    n, ns, na = nm.n, nm.ns, nm.na
    parts = np.split(v, np.cumsum([n * n, n * n, ns * n]))
    return {"Omega": parts[0].reshape(n, n), "Gamma": parts[1].reshape(n, n),
            "cphi": parts[2].reshape(ns, n), "phib": parts[3].reshape(n, na)}
