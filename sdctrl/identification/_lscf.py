"""Algebraic initial poles: least-squares complex-frequency (LSCF) estimator (thesis 3.1.2).

A polynomial (rational fraction) model (3.1)-(3.2) with a common denominator,
``H_o(z) = N_o(z) / d(z)``, is fitted by *linear* least squares to a few principal
responses of the band, the leading left singular directions of the stacked FRF (linear
combinations of the measured FRFs, so they share the poles).  It serves the modal
identification of section 3.2 the way the thesis intends: "another identification
method is used to provide the initial guess", whose computational poles are then
eliminated.

* Frequency map: the band ``[w_lo, w_hi]`` (rad/s) is mapped onto the arc
  ``theta = (w - w_c) dt`` of the unit circle, ``|theta| <= 0.9 pi`` (``w_c`` the centre),
  ``z = exp(i theta)``: the powers ``z^m`` are nearly orthogonal there, so the problem is
  well conditioned at any order, and complex coefficients model the positive-frequency
  poles only (the conjugate poles are smooth in the band).  A root ``z_p`` of ``d`` gives
  the pole ``lambda = ln(z_p) / dt + i w_c``.
* Linear least squares: the equation error ``N_o(z_k) - H_o(k) d(z_k)`` over lines ``k``
  and principal responses ``o``; eliminating the numerators leaves the reduced normal
  matrix ``D = sum_o (T_o - S_o^H R^-1 S_o)`` of the denominator coefficients, with
  Toeplitz ``R``, ``S_o``, ``T_o`` built from the ``2n + 1`` moments ``sum_k x_k z_k^m``
  (any frequency grid).  With the Cholesky factor ``R = L L^H`` of the largest order,
  every lower order's ``D`` is a leading block of running sums (``L^-1`` is lower
  triangular), so all orders cost little more than the largest.
* Each order ``n`` gives the monic least-squares denominator (``alpha_n = 1``) and its
  roots (companion eigenvalues).  Physical poles are stable from one order to the next;
  computational poles wander.  A pole is kept when the next lower order computed has a
  pole within ``freq_tol`` (relative) in frequency and ``damping_tol`` in damping ratio.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.triangular import solve_lower

__all__ = ["lscf_poles", "principal_responses", "stable_poles"]

#: fraction of the half circle the band is mapped onto
ARC = 0.9


def principal_responses(Y: np.ndarray, r: int) -> np.ndarray:
    """The ``r`` leading principal responses of stacked data ``Y = [Re H; Im H]`` (2nf, k).

    Parameters
    ----------
    Y : ndarray, shape (2 nf, k)
        Real stacked data (columns: real combinations of the FRFs).
    r : int
        Number of responses.

    Returns
    -------
    ndarray, shape (nf, min(r, k)), complex
        ``H W`` with ``W`` the leading right singular vectors of ``Y`` (real), scaled by
        their singular values.
    """
    nf = Y.shape[0] // 2
    Hc = Y[:nf] + 1j * Y[nf:]
    k = Y.shape[1]
    if k <= r:
        return Hc
    _ev, W = np.linalg.eigh(Y.T @ Y)
    return Hc @ W[:, ::-1][:, :r]


def lscf_poles(freq: np.ndarray, P: np.ndarray, orders) -> list[np.ndarray]:
    """Poles (rad/s) of the LSCF common-denominator model of each order (module notes).

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Frequency lines (Hz), increasing.
    P : ndarray, shape (nf, r), complex
        Responses sharing the poles (principal responses).
    orders : sequence of int
        Denominator orders, each below ``nf``.

    Returns
    -------
    list of ndarray of complex
        All the roots of each order's denominator as continuous poles (rad/s), unsorted
        and unfiltered (stable and unstable, any frequency).
    """
    orders = [int(n) for n in orders]
    nmax = max(orders)
    w = 2 * np.pi * np.asarray(freq, float)
    wc = 0.5 * (w[0] + w[-1])
    half = max(0.5 * (w[-1] - w[0]), 1e-300)
    dt = ARC * np.pi / half
    theta = (w - wc) * dt
    m = np.arange(-nmax, nmax + 1)
    Z = np.exp(1j * theta[:, None] * m[None, :])                # (nf, 2 nmax + 1)
    P = P / max(float(np.sqrt(np.sum(np.abs(P) ** 2))), 1e-300)
    X = np.column_stack([np.ones(w.size), P, np.sum(np.abs(P) ** 2, axis=1)])
    mom = X.T @ Z                                              # moments, (r + 2, 2 nmax + 1)
    idx = np.arange(nmax + 1)
    lag = idx[None, :] - idx[:, None] + nmax                   # (l - j) + nmax
    R = mom[0][lag]
    T = mom[-1][lag]
    S = mom[1:-1][:, lag]                                      # (r, nmax+1, nmax+1)
    L = np.linalg.cholesky(R + 1e-13 * np.real(R[0, 0]) * np.eye(nmax + 1))
    Wk = np.stack([solve_lower(L, So) for So in S])
    # row i of L^-1 S_o only involves rows <= i: order n uses rows 0..n, columns 0..n
    G = np.einsum("oij,oik->ijk", Wk.conj(), Wk)               # (nmax+1, nmax+1, nmax+1)
    C = np.cumsum(G, axis=0)
    out = []
    for n in orders:
        D = T[:n + 1, :n + 1] - C[n, :n + 1, :n + 1]
        try:
            a = np.linalg.solve(D[:n, :n], -D[:n, n])
        except np.linalg.LinAlgError:
            a = np.linalg.lstsq(D[:n, :n], -D[:n, n], rcond=None)[0]
        zr = np.roots(np.concatenate([[1.0], a[::-1]]))
        zr = zr[np.abs(zr) > 0]
        out.append(np.log(zr) / dt + 1j * wc)
    return out


def _physical(p, fband, zeta_max):
    """Frequencies (Hz) and damping ratios of the stable, in-band poles of ``p``."""
    p = p[(p.imag > 0) & (p.real < 0)]
    f = np.abs(p) / (2 * np.pi)
    z = -p.real / np.abs(p)
    ok = (f >= fband[0]) & (f <= fband[1]) & (z <= zeta_max)
    return f[ok], z[ok]


def stable_poles(poles: list[np.ndarray], fband, zeta_max: float, depth: int = 3,
                 freq_tol: float = 0.25, damping_tol: float = 0.25):
    """In-band physical poles of the last order that the ``depth - 1`` previous orders
    confirm.

    A pole of order ``n_k`` is confirmed by order ``n_(k-1)`` when that order has a pole
    within ``freq_tol`` half-power bandwidths ``zeta f`` in frequency and within
    ``damping_tol`` (relative) in damping ratio; the chain is followed down from the
    last order.  Two kept poles closer than a third of the smaller half-power bandwidth
    are merged (one mode split in two roots).

    Parameters
    ----------
    poles : list of ndarray
        Poles (rad/s) of increasing orders (:func:`lscf_poles`).
    fband : (float, float)
        Band in Hz.
    zeta_max : float
        Largest damping ratio kept.
    depth : int
        Number of orders the pole must appear in (the last ``depth`` ones).
    freq_tol, damping_tol : float
        Tolerances of the stability test (see above).

    Returns
    -------
    w : ndarray
        Natural frequencies (rad/s), increasing.
    z : ndarray
        Damping ratios.
    """
    f, z = _physical(poles[-1], fband, zeta_max)
    keep = np.ones(f.size, bool)
    fc, zc = f, z
    for p in poles[-2:-depth - 1:-1] if depth > 1 else []:
        fp, zp = _physical(p, fband, zeta_max)
        if fp.size == 0 or not keep.any():
            keep[:] = False
            break
        j = np.argmin(np.abs(fc[:, None] - fp[None, :]), axis=1)
        keep &= (np.abs(fc - fp[j]) <= freq_tol * zc * fc) & \
                (np.abs(zc - zp[j]) <= damping_tol * zc)
        fc, zc = fp[j], zp[j]
    order = np.argsort(f[keep])
    f, z = f[keep][order], z[keep][order]
    # one mode split into two stable roots (seen on noisy MIMO data): closer than a
    # third of the smaller half-power bandwidth, they are one pole (distinct close
    # modes are further apart: beyond that they are not resolved by the data anyway)
    i = 0
    while i < f.size - 1:
        if f[i + 1] - f[i] < min(z[i] * f[i], z[i + 1] * f[i + 1]) / 3:
            f[i] = 0.5 * (f[i] + f[i + 1])
            z[i] = np.sqrt(z[i] * z[i + 1])
            f, z = np.delete(f, i + 1), np.delete(z, i + 1)
        else:
            i += 1
    return 2 * np.pi * f, z
