"""Uncertain residual dynamics: the complex modes a normal-mode model keeps as they are (3.7).

An identified normal-mode model keeps the poles that cannot be normal modes (fitted outside
the band, or whose properness cannot be enforced) as complex-mode terms
``R_j / (s - lambda_j) + conj(R_j) / (s - conj(lambda_j))`` (:class:`~sdctrl.modal.
ResidualDynamics`).  The test determines them no better than the modes: their poles and
residues carry the identification's standard deviations (3.56), (3.58).  Left certain, they
wander from one test to the next outside the uncertain model's envelope.

For the perturbation to enter affinely (an exact LFT, as 5.5 for the modes) each term is
realised in complex modal coordinates, one per pole and actuator: ``xi' = lambda xi + u_a``,
``y = 2 Re(R[:, a] xi)``; with ``xi = x1 + i x2``,

    ``A = [[Re l, -Im l], [Im l, Re l]]``, ``B = [1; 0]``, ``C = [2 Re R, -2 Im R]``.

A shift of ``Re l`` is then ``delta I`` on the block (a real scalar repeated twice per
actuator), of ``Im l`` is ``delta [[0, -1], [1, 0]]``, and a residue entry's real or imaginary
part moves one entry of ``C``.  Parameters (as :func:`~sdctrl.robust._uncertainty.uncertain`
lists them): ``("rsig", j, 0)`` and ``("romg", j, 0)`` with repetition ``2 na``, ``("rre", j,
s na + a)`` and ``("rim", j, s na + a)`` with repetition 1.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["KINDS", "residual_channels", "residual_matrices", "residual_params",
           "residual_perturbed", "residual_states"]

#: parameter kinds of the residual dynamics
KINDS = ("rsig", "romg", "rre", "rim")


def residual_params(dpoles, dresidues) -> list:
    """Parameter entries ``(name, (kind, j, k), repetition, bound)`` of the bounds.

    Parameters
    ----------
    dpoles : ndarray, shape (m,), complex
        Bounds on ``Re l`` (``.real``) and ``Im l`` (``.imag``), rad/s (0: certain).
    dresidues : ndarray, shape (m, ns, na), complex
        Bounds on ``Re R`` and ``Im R`` of each entry at the model's I/O.

    Returns
    -------
    list
    """
    m, ns, na = dresidues.shape
    out = []
    for j in range(m):
        for kind, b in (("rsig", dpoles[j].real), ("romg", dpoles[j].imag)):
            if b > 0:
                out.append((f"delta_{kind}_{j}", (kind, j, 0), 2 * na, float(b)))
    for kind, part in (("rre", dresidues.real), ("rim", dresidues.imag)):
        for j, s, a in zip(*np.nonzero(part)):
            out.append((f"delta_{kind}_{j}_{s}_{a}", (kind, int(j), int(s * na + a)), 1,
                        float(part[j, s, a])))
    return out


def residual_matrices(poles, residues):
    """``A, B, C`` of the terms in complex modal coordinates (module notes), displacement.

    Parameters
    ----------
    poles : ndarray, shape (m,), complex
    residues : ndarray, shape (m, ns, na), complex

    Returns
    -------
    A : ndarray, shape (2 m na, 2 m na)
    B : ndarray, shape (2 m na, na)
    C : ndarray, shape (ns, 2 m na)
    """
    m, ns, na = residues.shape
    nx = 2 * m * na
    A, B, C = np.zeros((nx, nx)), np.zeros((nx, na)), np.zeros((ns, nx))
    for j in range(m):
        sig, om = poles[j].real, poles[j].imag
        for a in range(na):
            b = 2 * (j * na + a)
            A[b:b + 2, b:b + 2] = [[sig, -om], [om, sig]]
            B[b, a] = 1.0
            C[:, b] = 2 * residues[j, :, a].real
            C[:, b + 1] = -2 * residues[j, :, a].imag
    return A, B, C


def residual_states(m: int, na: int) -> list:
    """State names ``r{j}_{a}`` (real part) and ``ri{j}_{a}`` (imaginary part)."""
    return [f"{p}{j}_{a}" for j in range(m) for a in range(na) for p in ("r", "ri")]


def residual_perturbed(poles, residues, params, deltas):
    """Poles and residues moved by the residual parameters' normalised values.

    Parameters
    ----------
    poles, residues : ndarray
        Nominal values (placed on the model's I/O).
    params : list
        Every parameter of the uncertain model (the others are skipped).
    deltas : ndarray
        Normalised values, one per parameter.

    Returns
    -------
    poles, residues : ndarray (new arrays)
    """
    lam, R = np.array(poles, complex), np.array(residues, complex)
    na = R.shape[2]
    for (_, (kind, j, k), _, beta), d in zip(params, deltas):
        if kind == "rsig":
            lam[j] += beta * d
        elif kind == "romg":
            lam[j] += 1j * beta * d
        elif kind == "rre":
            R[j, k // na, k % na] += beta * d
        elif kind == "rim":
            R[j, k // na, k % na] += 1j * beta * d
    return lam, R


def residual_channels(kind: str, j: int, k: int, beta: float, first: int, na: int) -> list:
    """``(drive, coefficient, read)`` of each channel of one residual parameter.

    Drives ``("xd", i)`` add to the derivative of state ``i``, ``("y", s)`` to sensor ``s``;
    reads ``("x", i)`` are states.  ``first`` is the index of the first residual state.
    """
    if kind in ("rsig", "romg"):
        out = []
        for a in range(na):
            b = first + 2 * (j * na + a)
            if kind == "rsig":
                out += [(("xd", b), beta, ("x", b)), (("xd", b + 1), beta, ("x", b + 1))]
            else:
                out += [(("xd", b), -beta, ("x", b + 1)), (("xd", b + 1), beta, ("x", b))]
        return out
    s, a = divmod(k, na)
    b = first + 2 * (j * na + a)
    if kind == "rre":
        return [(("y", s), 2 * beta, ("x", b))]
    return [(("y", s), -2 * beta, ("x", b + 1))]
