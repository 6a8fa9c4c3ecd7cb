"""What a hybrid model keeps of the test at the tested inputs and outputs (thesis 5.1.1,
beyond it).

At the tested I/O the test has measured the whole response, not only its normal modes: the
identified model ``nm`` holds, besides the in-band normal modes, the out-of-band poles kept
as complex-mode residual dynamics (3.7, ``nm.residual``), the residual flexibility ``E``
and the residual mass ``F`` (2.19)-(2.24).  The hybrid's appended FE modes stand for the
same out-of-band dynamics, but with the FE model's errors (a wrong FE mode can land in the
band).  So, at the tested sensors, the hybrid keeps what the test measured:

- the measured modes with their identified observabilities ``(c phi)_ID`` and ``phib``;
- the identified residual dynamics, ``E`` and ``F`` (and, as complex-mode terms, the
  identified normal modes that no FE mode pairs with: ``absorbed``);
- the appended and low FE modes unobserved there (their tested-sensor observabilities
  offset to zero, as the identified ``E`` is carried, 2.22), so they are not counted twice;
- the static correction modes of the test inputs observed with their FE shapes plus an
  offset ``D`` fitted so that the model reproduces ``nm`` over the band (the residual
  flexibility carried by the correction modes, 2.22, as :func:`sdctrl.hybrid` always did).

The FE modes keep their shapes: predictions at untested outputs and inputs
(:meth:`~sdctrl.hybrids.HybridModel.with_io`, which drops the tested-sensor offsets) and
modifications (5.2)-(5.4) use them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.modal._normal_model import NormalModeModel
from sdctrl.modal._residual_dynamics import ResidualDynamics

__all__ = ["ABSORBED", "TestedIO", "keep_tested", "realise_residual"]

#: reason recorded for an identified normal mode absorbed into the residual dynamics
ABSORBED = "absorbed by the hybrid: no FE mode pairs with it (MAC below mac_min)"


@dataclass(frozen=True, eq=False)
class TestedIO:
    """The hybrid's modes and what it carries at the tested I/O (:func:`keep_tested`).

    Attributes
    ----------
    w2 : ndarray, shape (n,)
        ``omega^2`` of the hybrid's modes (rad/s)^2.
    Gamma : ndarray, shape (n, n)
        Their damping (rad/s).
    cphi : ndarray, shape (ns, n)
        Observabilities at the tested sensors (FE shapes plus the offsets).
    phib : ndarray, shape (n, na)
        Controllabilities of the tested inputs.
    kind : ndarray of str, shape (n,)
        ``"measured"``, ``"fe"``, ``"residual"``, ``"static"``.
    """

    w2: np.ndarray
    Gamma: np.ndarray
    cphi: np.ndarray
    phib: np.ndarray
    kind: np.ndarray


def keep_tested(nm, absorbed, modes: TestedIO, w_band):
    """Observabilities and residual dynamics that keep ``nm`` at the tested I/O.

    Parameters
    ----------
    nm : NormalModeModel
        The identified model.
    absorbed : ndarray of int
        Modes of ``nm`` the hybrid does not keep as measured modes.
    modes : TestedIO
        The hybrid's modes, observabilities ``c phi + offset`` of :func:`sdctrl.hybrid`.
    w_band : ndarray
        Lines of the test band (rad/s), increasing.

    Returns
    -------
    cphi : ndarray, shape (ns, n)
        Tested-sensor observabilities: the measured modes' as given, every other mode's
        zero (an offset of ``-c phi``, carried as ``E`` is, 2.22).
    offset_flexibility : ndarray, shape (ns, na), or None
        The static term those offsets add through the static correction modes of the test
        inputs, ``(cphi - c V) diag(1/w^2) phib`` (minus the FE static response that the
        test's ``E`` replaces); None without correction modes.
    residual : ResidualDynamics or None
        ``nm.residual``, the absorbed modes as complex-mode terms (3.7) and ``nm.E`` as a
        correction term far above the band (:func:`flexibility_term`), the residues of the
        terms above the band refitted so that the band error of that term is carried
        (:func:`carry_flexibility`).
    """
    kind = modes.kind
    meas = kind == "measured"
    r = (kind == "residual") & (modes.w2 > 0)
    cphi = np.array(modes.cphi, float)
    off = None
    if np.any(r):
        off = -cphi[:, r] @ (modes.phib[r] / modes.w2[r, None])
    cphi[:, ~meas] = 0.0
    residual = _with_absorbed(nm, absorbed)
    if nm.E is not None:
        w_band = np.asarray(w_band, float)
        residual = _joined(residual, flexibility_term(nm.E, CUTOFF * w_band[-1], nm.sensors,
                                                      nm.actuators))
        residual = carry_flexibility(residual, nm, w_band)
    return cphi, off, residual


#: the test's E is carried by a correction term this many times above the band's top: in
#: the band it differs from E by ``(w/w_c)^2 + 2 zeta w/w_c`` <= 0.8% of E's size, and the
#: state-space form stays within reach of the band integrals of ``sd.rms`` (a term 300x
#: above the band put the band RMS 20% off)
CUTOFF = 30.0
#: its damping ratio ``zeta``
CUTOFF_DAMPING = 0.1
#: reason recorded for it
FLEXIBILITY = ("residual flexibility E of the test (2.19)-(2.20), a correction term far "
               "above the band")


def flexibility_term(E, wc: float, sensors, actuators) -> ResidualDynamics:
    """``E wc^2 / (s^2 + 2 zeta wc s + wc^2)`` as one complex-mode term (3.7).

    Its static value is ``E`` and, in a band far below ``wc``, it differs from ``E`` by
    ``2 zeta w / wc`` (relative): the static term of a tested I/O realised exactly in the
    state-space form (3.26)-(3.33) for every quantity, at that I/O only.

    Parameters
    ----------
    E : ndarray, shape (ns, na)
        Static (residual flexibility) term of the displacement response.
    wc : float
        Cut-off (rad/s).
    sensors, actuators : sequence of str
        Labels of the I/O it belongs to.

    Returns
    -------
    ResidualDynamics
    """
    z = CUTOFF_DAMPING
    lam = wc * (-z + 1j * np.sqrt(1 - z**2))
    R = np.asarray(E, float)[None] * wc**2 / (2j * lam.imag)
    return ResidualDynamics(np.array([lam]), R, sensors=sensors, actuators=actuators,
                            reasons=(FLEXIBILITY,))


def carry_flexibility(res: ResidualDynamics, nm, w_band) -> ResidualDynamics:
    """The band error of the flexibility term (``res``'s last pole) carried by the terms
    above the band.

    The term differs from ``E`` in the band by ``E (g - 1)`` (:data:`CUTOFF`), negligible
    against ``E`` but not against the response where ``E`` nearly cancels the tails of the
    out-of-band poles (``E`` 1200x the response at a line of a level-weighted fit of
    truss_high: the hybrid's nominal logLS was twice ``nm``'s; the ladder at 1%, 0.00075
    against 0.00060).  Terms at the poles above the band (the flexibility term's own and
    ``nm.residual``'s above it) get imaginary residues ``dR`` (terms ``b / (s^2 + 2 zeta w s
    + w^2)``: proper in acceleration, so realised exactly; real parts made the realisation
    of the default testbed's hybrid differ from its FRF by 2e-3) that reproduce ``E (1 -
    g)`` over the band lines, each tested channel by a least-squares fit weighted by ``1 /
    |H_nm|`` (the logLS cost linearised; the smallest ``dR`` where the terms are nearly
    dependent).  The flexibility term takes its own ``dR``; the others are appended as
    terms of their own (``nm.residual`` is kept as it is), with :data:`CARRIED` as their
    reason.
    """
    E = np.asarray(nm.E, float)
    far = np.flatnonzero(np.abs(res.poles) > w_band[-1])
    s, lam = 1j * w_band, res.poles[far]
    g = 1.0 / (s[:, None] - lam[None, :])
    gc = 1.0 / (s[:, None] - lam.conj()[None, :])
    basis = 1j * (g - gc)               # imaginary residues: proper in acceleration too
    scale = np.abs(basis).max(axis=0)
    lc = res.poles[-1]
    miss = 1.0 - abs(lc) ** 2 / ((s - lc) * (s - lc.conj()))          # 1 - g over the band
    h = np.abs(nm.frf(w_band / (2 * np.pi)).H)
    dR = np.zeros((far.size,) + E.shape, complex)
    for i, j in np.ndindex(*E.shape):
        wgt = 1.0 / np.maximum(h[:, i, j], 1e-300)
        A, b = basis / scale * wgt[:, None], miss * E[i, j] * wgt
        x = np.linalg.lstsq(np.concatenate([A.real, A.imag]),
                            np.concatenate([b.real, b.imag]), rcond=1e-10)[0] / scale
        dR[:, i, j] = 1j * x
    R = np.array(res.placed(nm.sensors, nm.actuators), complex)
    R[-1] += dR[-1]
    n_res = far.size - 1
    return ResidualDynamics(np.concatenate([res.poles, lam[:n_res]]),
                            np.concatenate([R, dR[:n_res]]), sensors=nm.sensors,
                            actuators=nm.actuators, reasons=res.reasons + (CARRIED,) * n_res)


#: reason recorded for the terms that carry the flexibility term's band error
CARRIED = ("the band error of the flexibility term E (its static value far above the band) "
           "carried at a pole of the test above the band")


def _joined(a, b):
    """Two residual blocks on the same I/O as one (``a`` may be None)."""
    if a is None:
        return b
    return ResidualDynamics(np.concatenate([a.poles, b.poles]),
                            np.concatenate([a.residues, b.residues]), sensors=a.sensors,
                            actuators=a.actuators, reasons=a.reasons + b.reasons)


def _with_absorbed(nm, absorbed):
    """``nm.residual`` with the absorbed normal modes of ``nm`` as complex-mode terms."""
    res = nm.residual
    k = np.asarray(absorbed, int)
    if k.size == 0:
        return res
    Om, Ga = nm.Omega[np.ix_(k, k)], nm.Gamma[np.ix_(k, k)]
    n = k.size
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Om, -Ga]])
    lam, V = np.linalg.eig(A)
    up = lam.imag > 0
    lam, psi = lam[up], V[:n, up]
    psi = psi / np.sqrt(np.einsum("ij,ij->j", psi, 2 * lam[None, :] * psi + Ga @ psi))
    R = np.einsum("ij,kj->jik", nm.cphi[:, k] @ psi, nm.phib[k].T @ psi)   # (2.9)
    poles, reasons = list(lam), [ABSORBED] * lam.size
    if res is not None:
        R = np.concatenate([res.placed(nm.sensors, nm.actuators), R])
        poles, reasons = list(res.poles) + poles, list(res.reasons) + reasons
    return ResidualDynamics(np.array(poles), R, sensors=nm.sensors, actuators=nm.actuators,
                            reasons=tuple(reasons))


def realise_residual(cphi, w2, phib, kinds, E):
    """The kept residual flexibility ``E`` carried by the static correction modes (2.22).

    As the thesis incorporates the asymptotic term in the correction modes (2.22), the
    observabilities of the static correction modes of the test inputs get ``D`` with
    ``D diag(1/w^2) phib_r = E``: the model's static response at the tested I/O holds
    ``E`` exactly, its realisation (:meth:`~NormalModeModel.to_statespace`) is exact for
    every quantity, and ``E`` is dropped with them when the inputs change
    (:meth:`HybridModel.with_io`).  What the modes cannot carry (rank) stays in ``E``.

    Parameters
    ----------
    cphi : ndarray, shape (ns, n)
        Tested-sensor observabilities of the modes.
    w2, phib, kinds : ndarray
        Their ``omega^2`` (rad/s)^2, controllabilities and kinds.
    E : ndarray, shape (ns, na), or None
        The kept residual flexibility.

    Returns
    -------
    cphi : ndarray, shape (ns, n)
        With the correction modes' offsets ``D``.
    E : ndarray or None
        What they cannot carry.
    """
    if E is None:
        return cphi, None
    r = np.isin(kinds, ("residual", "static")) & (w2 > 0)
    if not np.any(r):
        return cphi, E
    X = phib[r] / w2[r, None]
    D = E @ np.linalg.pinv(X, rcond=1e-10)
    left = E - D @ X
    cphi = np.array(cphi)
    cphi[:, r] += D
    tiny = 1e-9 * max(np.abs(E).max(), 1e-300)
    return cphi, (left if np.abs(left).max() > tiny else None)
