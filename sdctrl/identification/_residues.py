"""Pole basis and least-squares residues (thesis 3.2.1, eq. 3.6-3.9, 3.15-3.17).

For a set of poles the FRF model is linear in the residues and asymptotic terms,
``H = Phi(lambda) R`` (3.15).  Conjugate symmetry (3.7) is kept *exactly* by giving
every pole two basis functions with real coefficients: writing ``R_j = a_j + i b_j``,

``R_j/(s - l_j) + R_j^*/(s - l_j^*) = a_j g1_j(s) + b_j g2_j(s)``,
``g1 = 1/(s - l) + 1/(s - l^*)``, ``g2 = i/(s - l) - i/(s - l^*)``,

followed by ``1`` (real residual flexibility ``E``) and ``1/s^2`` (real residual mass
``F``).  The real-mode parametrisation (3.9) uses one basis function per pole,
``1/((s - l)(s - l^*))``, with real coefficient ``T_j``, i.e. ``R_j = T_j / (l - l^*)``.
Complex data are stacked as ``[Re; Im]`` so that the least-squares problem (3.16) is
real and its coefficients stay real; it is solved by a QR factorisation of the
column-scaled basis (never the normal equations 3.17).  A measured velocity or
acceleration multiplies every basis function by ``s`` or ``s^2``, so the residues always
describe the displacement response.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.triangular import solve_upper

__all__ = [
    "basis",
    "basis_derivative",
    "basis_derivatives",
    "coefficients_to_model",
    "pole_from_params",
    "solve",
    "stack",
]


def pole_from_params(w: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Pole ``-z w + i w sqrt(1 - z^2)`` from natural frequency ``w`` (rad/s) and damping.

    Parameters
    ----------
    w : ndarray
        Natural frequencies (rad/s).
    z : ndarray
        Damping ratios in ``[0, 1)``.

    Returns
    -------
    ndarray
        Complex poles (upper half-plane).

    Examples
    --------
    >>> import numpy as np
    >>> complex(pole_from_params(np.array(2.0), np.array(0.6)))
    (-1.2+1.6j)
    """
    return -z * w + 1j * w * np.sqrt(1.0 - z**2)


def stack(X: np.ndarray) -> np.ndarray:
    """Real stacking ``[Re X; Im X]`` along the first axis.

    Parameters
    ----------
    X : ndarray
        Complex array.

    Returns
    -------
    ndarray
        Real array with twice the first dimension.
    """
    return np.concatenate([X.real, X.imag], axis=0)


def n_per_pole(model: str) -> int:
    return 2 if model == "complex" else 1


def basis(lam: np.ndarray, s: np.ndarray, k: int, model: str = "complex",
          asymptotic: tuple[bool, bool] = (True, True), weight=None) -> np.ndarray:
    """Complex pole basis ``Phi`` (nf, p) of (3.15) times ``s^k`` (measured quantity).

    Columns: two per pole (``g1``, ``g2``) for ``model="complex"``, one per pole for
    ``model="real"``, then ``1`` (E) and ``1/s^2`` (F) when ``asymptotic`` asks for them.

    Parameters
    ----------
    lam : ndarray, shape (n,)
        Poles (rad/s), upper half-plane.
    s : ndarray, shape (nf,)
        Laplace points ``j w`` (rad/s).
    k : int
        Power of ``s`` of the measured quantity (0, 1, 2: displacement, velocity,
        acceleration).
    model : {"complex", "real"}
        Complex-mode (3.7) or real-mode (3.9) parametrisation.
    asymptotic : (bool, bool)
        Whether to append the ``E`` and ``F`` columns.
    weight : ndarray, shape (nf,), optional
        Weight of each line (:mod:`~sdctrl.identification._line_weights`): the rows are
        multiplied by it, as the data's are.

    Returns
    -------
    ndarray, shape (nf, p), complex
    """
    lam = np.asarray(lam, complex)
    n = lam.size
    npp = 2 if model == "complex" else 1
    Phi = np.empty((s.size, npp * n + sum(asymptotic)), complex)
    a = 1.0 / (s[:, None] - lam[None, :])
    b = 1.0 / (s[:, None] - lam.conj()[None, :])
    if model == "complex":
        Phi[:, 0:2 * n:2] = a + b
        Phi[:, 1:2 * n:2] = 1j * (a - b)
    else:
        Phi[:, :n] = a * b
    i = npp * n
    if asymptotic[0]:
        Phi[:, i] = 1.0
        i += 1
    if asymptotic[1]:
        Phi[:, i] = 1.0 / s**2
    if k:
        Phi = Phi * (s**k)[:, None]
    return Phi if weight is None else Phi * weight[:, None]


def basis_derivative(lam: complex, w: float, z: float, s: np.ndarray, k: int,
                     model: str = "complex") -> tuple[np.ndarray, np.ndarray]:
    """Derivatives of one pole's basis columns w.r.t. ``ln w`` and ``ln z`` (nf, 1 or 2) each.

    ``d lambda / d ln w = lambda`` and ``d lambda / d ln z = z (-w - i w z / sqrt(1-z^2))``,
    the ingredients of the gradient (3.19).

    Parameters
    ----------
    lam : complex
        The pole (rad/s).
    w, z : float
        Its natural frequency (rad/s) and damping ratio.
    s : ndarray, shape (nf,)
        Laplace points (rad/s).
    k : int
        Power of ``s`` of the measured quantity.
    model : {"complex", "real"}
        Parametrisation (3.7) or (3.9).

    Returns
    -------
    d_ln_w, d_ln_z : ndarray, shape (nf, 1 or 2)
    """
    dl = (lam, z * (-w - 1j * w * z / np.sqrt(1.0 - z**2)))
    sk = (s**k)[:, None] if k else 1.0
    a = 1.0 / (s - lam)
    b = 1.0 / (s - np.conj(lam))
    out = []
    for d in dl:
        da = d * a**2                      # d/dtheta 1/(s - l)
        db = np.conj(d) * b**2             # d/dtheta 1/(s - l^*)
        if model == "complex":
            g = np.stack([da + db, 1j * (da - db)], axis=1)
        else:
            g = (da * b + a * db)[:, None]
        out.append(g * sk)
    return out[0], out[1]


def basis_derivatives(lam: np.ndarray, w: np.ndarray, z: np.ndarray, s: np.ndarray, k: int,
                      model: str = "complex", weight=None) -> np.ndarray:
    """:func:`basis_derivative` for several poles at once.

    Parameters
    ----------
    lam : ndarray, shape (n,)
        Poles (rad/s).
    w, z : ndarray, shape (n,)
        Their natural frequencies (rad/s) and damping ratios.
    s : ndarray, shape (nf,)
        Laplace points (rad/s).
    k : int
        Power of ``s`` of the measured quantity.
    model : {"complex", "real"}
        Parametrisation (3.7) or (3.9).
    weight : ndarray, shape (nf,), optional
        Weight of each line (as :func:`basis`).

    Returns
    -------
    ndarray, shape (2, nf, n, npp), complex
        Derivatives w.r.t. ``ln w`` (index 0) and ``ln z`` (index 1) of each pole's columns.
    """
    lam = np.asarray(lam, complex)
    dl = np.stack([lam, z * (-w - 1j * w * z / np.sqrt(1.0 - z**2))])[:, None, :]
    a = 1.0 / (s[:, None] - lam[None, :])
    b = 1.0 / (s[:, None] - np.conj(lam)[None, :])
    da = dl * a**2
    db = np.conj(dl) * b**2
    if model == "complex":
        g = np.stack([da + db, 1j * (da - db)], axis=-1)
    else:
        g = (da * b + a * db)[..., None]
    if k:
        g = g * (s**k)[None, :, None, None]
    return g if weight is None else g * weight[None, :, None, None]


class LSQ:
    """QR solution of the real stacked least-squares problem ``min ||Y - A C||_F`` (3.16).

    ``A = [Re Phi; Im Phi]`` is column-scaled before a QR factorisation (economic,
    Householder through LAPACK); ``C`` are the real coefficients of the *unscaled*
    basis.  ``Y`` may be given split as complex ``H`` (nf, m): ``Q^T Y`` is then formed as
    ``Q_1^T Re H + Q_2^T Im H`` without copying ``H``.
    """

    def __init__(self, Phi: np.ndarray):
        A = stack(Phi)
        scale = np.linalg.norm(A, axis=0)
        scale[scale == 0] = 1.0
        self.scale = scale
        self.nf = Phi.shape[0]
        self.Q, self.Rr = np.linalg.qr(A / scale)
        d = np.abs(np.diag(self.Rr))
        self.rcond = float(d.min() / d.max()) if d.size else 1.0

    def project(self, H: np.ndarray) -> np.ndarray:
        """``Q^T [Re H; Im H]`` for complex ``H`` (nf, m) or real stacked ``Y`` (2nf, m)."""
        if np.iscomplexobj(H):
            nf = self.nf
            return self.Q[:nf].T @ H.real + self.Q[nf:].T @ H.imag
        return self.Q.T @ H

    def residual2(self, H: np.ndarray, QtY: np.ndarray) -> float:
        """``||Y - Q Q^T Y||^2`` from the residual itself, for ``H`` as in :meth:`project`
        and ``QtY`` its projection (``||Y||^2 - ||Q^T Y||^2`` cancels: an exact fit would
        read a relative cost of ``sqrt(eps)``, 1e-8)."""
        if np.iscomplexobj(H):
            nf = self.nf
            return float(np.sum((H.real - self.Q[:nf] @ QtY) ** 2)
                         + np.sum((H.imag - self.Q[nf:] @ QtY) ** 2))
        return float(np.sum((H - self.Q @ QtY) ** 2))

    def coefficients(self, QtY: np.ndarray) -> np.ndarray:
        C = solve_upper(self.Rr, QtY)
        return C / self.scale[:, None]


def solve(Phi: np.ndarray, H: np.ndarray, normH2: float | None = None):
    """Least-squares coefficients and cost for basis ``Phi`` (nf, p) and data ``H`` (3.16).

    Parameters
    ----------
    Phi : ndarray, shape (nf, p), complex
        Pole basis (:func:`basis`).
    H : ndarray, shape (nf, m), complex
        Data, one column per sensor/actuator pair.
    normH2 : float, optional
        ``||H||_F^2`` when already known.

    Returns
    -------
    C : ndarray, shape (p, m), real
        Coefficients.
    cost : float
        ``||Y - A C||_F^2`` (stacked real residual).
    lsq : LSQ
        The QR factorisation, reusable for other data.
    """
    lsq = LSQ(Phi)
    QtY = lsq.project(H)
    if normH2 is None:
        normH2 = float(np.sum(np.abs(H) ** 2))
    cost = max(normH2 - float(np.sum(QtY**2)), 0.0)
    return lsq.coefficients(QtY), cost, lsq


def coefficients_to_model(C: np.ndarray, lam: np.ndarray, model: str,
                          asymptotic: tuple[bool, bool], ns: int, na: int):
    """Residues (n, ns, na) complex and real ``E``, ``F`` (ns, na) from coefficients ``C``.

    Parameters
    ----------
    C : ndarray, shape (p, ns * na), real
        Least-squares coefficients (:func:`solve`).
    lam : ndarray, shape (n,)
        Poles (rad/s).
    model : {"complex", "real"}
        Parametrisation (3.7) or (3.9).
    asymptotic : (bool, bool)
        Whether ``C`` holds the ``E`` and ``F`` rows.
    ns, na : int
        Numbers of sensors and actuators.

    Returns
    -------
    R : ndarray, shape (n, ns, na), complex
    E, F : ndarray, shape (ns, na)
    """
    n = lam.size
    if model == "complex":
        a = C[0:2 * n:2]
        b = C[1:2 * n:2]
        R = (a + 1j * b).reshape(n, ns, na)
        i = 2 * n
    else:
        T = C[:n]
        R = (T / (lam - np.conj(lam))[:, None]).reshape(n, ns, na)
        i = n
    E = np.zeros((ns, na))
    F = np.zeros((ns, na))
    if asymptotic[0]:
        E = C[i].reshape(ns, na).copy()
        i += 1
    if asymptotic[1]:
        F = C[i].reshape(ns, na).copy()
    return R, E, F
