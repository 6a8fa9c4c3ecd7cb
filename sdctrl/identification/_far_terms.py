"""One more out-of-band term per side after the automatic selection, kept only where the data
need it and it is passive (issue 22).

The selection (:mod:`~sdctrl.identification._selection`) adds out-of-band poles while they
converge away from the bounds of their search (a factor ``OUT_FACTOR`` from the band edges)
and are significant.  What it leaves is carried by the asymptotic terms ``E`` and ``F/s^2``
(3.6)-(3.9); but ``F/s^2`` is only the first term of the roll-off of the modes below the
band,

    sum_k R_k / (s^2 + w_k^2) = (sum_k R_k) / s^2 - (sum_k R_k w_k^2) / s^4 + ...,

and with several modes below the band (suspension modes, a mode just below the edge) the
next term can stand above the noise of the quieter channels while no single pole converges
inside the search's bounds: at 1% noise the cost is flat in the pole's position and its
optimum lies at the far bound, where the pole's residue and ``F`` (or ``E``, above) become
large and of opposite signs -- a non-passive decomposition (``F_cc < 0``: a negative
residual mass at a collocated pair), whose realisation (``F``'s correction modes a decade
below the band, the improper part of a velocity or acceleration model) then loses what the
fit gained, and whose feedback loops may be unstable.

So the term is *placed*, not searched: on a geometric grid of :data:`PLACES` frequencies
from just outside the band edge to the far bound, the term (damping held at the band's
median damping: the data do not determine it, as for the static correction modes of
(2.19)-(2.20)) is added with the other poles fixed, and the place of least cost is taken
among those where it is passive:

- its own residue is passive at every collocated pair: a real mode's displacement residue
  there is ``phi_c^2 / (2 j w_d)`` (2.10), so ``Im R_cc <= 0`` -- by the sign, since velocity
  feedback sees ``-Im R_cc / zeta`` at its resonance, however small the residue;
- no more of the other out-of-band poles and asymptotic terms are beyond passive than
  before: ``Im R_cc`` above 0, ``E_cc`` or ``F_cc`` below 0, by more than
  :data:`PASSIVE_SIGMA` standard deviations of the least-squares coefficients (3.16), or a
  pole at its lower damping bound with ``Im R_cc > 0`` at all.

The other poles are then refitted with the term held, and the term is kept when it is
significant (3.56), no pole is rejected and the passivity still holds; otherwise the model
stays as the selection left it.  Without collocated pairs no term is tried.  The selection
log records each trial (``"added"`` / ``"not added"`` and why).

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._residues import LSQ, basis, coefficients_to_model, pole_from_params
from sdctrl.identification._search import OUT_FACTOR, ZETA_MIN

__all__ = ["PASSIVE_SIGMA", "PLACES", "CollocatedResidues", "far_terms", "oob_grid"]

#: frequencies of the geometric grid between the band edge and the far bound
PLACES = 12
#: a coefficient beyond passive by more than this many standard deviations is not passive
PASSIVE_SIGMA = 3.0


def oob_grid(fband, sd, n=PLACES) -> np.ndarray:
    """Geometric grid (Hz) from just outside the band edge (3%) to just inside the far bound
    of the out-of-band search (5%) on side ``sd`` (-1 below, +1 above)."""
    edge = fband[0] if sd < 0 else fband[1]
    span = 0.95 * OUT_FACTOR if sd > 0 else 1 / (0.95 * OUT_FACTOR)
    return edge * (0.97 if sd < 0 else 1.03) * np.geomspace(1.0, span, n)


class CollocatedResidues:
    """Residues and asymptotic terms at the collocated pairs of the data (3.16).

    Parameters
    ----------
    H : ndarray, shape (nf, ns * na)
        The (scaled) data columns, sensor-major.
    na : int
        Number of actuators.
    pairs : sequence of (int, int)
        Collocated (sensor, actuator) pairs.
    prob : PoleProblem
        The pole search's problem (Laplace points, quantity power, parametrisation and
        asymptotic terms).
    """

    def __init__(self, H, na, pairs, prob):
        self.H = H[:, [i * na + j for i, j in pairs]]
        self.s, self.k, self.model, self.asym = prob.s, prob.k, prob.model, prob.asym
        self.weight = prob.weight                 # the search's line weights, on H too
        if self.weight is not None:
            self.H = self.H * self.weight[:, None]

    @classmethod
    def of(cls, data, H, prob):
        """Those of the FRF ``data`` (scaled columns ``H``), None without collocated pairs."""
        return cls(H, data.H.shape[2], data.collocated, prob) if data.collocated else None

    def passivity(self, w, z) -> np.ndarray:
        """How far each term is beyond passive, in standard deviations (n + m, pairs):
        ``Im R / std(Im R)`` of the poles ``(w rad/s, z)``, then ``-E / std(E)`` and
        ``-F / std(F)`` of the ``m`` asymptotic terms (the tail of a mode above or below
        the band leaves ``E_cc``, ``F_cc > 0``).  Standard deviations of the least-squares
        coefficients (3.16), each column's noise variance read from its residual (which
        holds the model error too: conservative)."""
        n = w.size
        lam = pole_from_params(w, z)
        lsq = LSQ(basis(lam, self.s, self.k, self.model, self.asym, self.weight))
        QtY = lsq.project(self.H)
        C = lsq.coefficients(QtY)
        R, _, _ = coefficients_to_model(C, lam, self.model, self.asym, 1, self.H.shape[1])
        r2 = np.array([lsq.residual2(self.H[:, [c]], QtY[:, [c]]) for c in range(C.shape[1])])
        sigma = np.sqrt(r2 / max(2 * self.H.shape[0] - C.shape[0], 1))
        npp = 2 if self.model == "complex" else 1
        rows = np.concatenate([npp * np.arange(n) + npp - 1, np.arange(npp * n, C.shape[0])])
        Rinv = np.linalg.inv(lsq.Rr)              # cov(C) = sigma^2 Rinv Rinv^T / scale^2
        std = np.linalg.norm(Rinv[rows], axis=1) / lsq.scale[rows]
        if self.model != "complex":               # Im R = -T / (2 w_d)
            std[:n] /= 2 * np.abs(lam.imag)
        value = np.concatenate([R[:, 0, :].imag, -C[npp * n:]])
        return value / np.maximum(std[:, None] * sigma[None, :], 1e-300)


def _beyond(state, collocated, new=None) -> np.ndarray:
    """Indices (poles, then ``E``, ``F``) of the out-of-band terms of ``state`` beyond
    passive at a collocated pair (module notes); the pole ``new`` by its sign alone."""
    w, z, side = state[:3]
    t = collocated.passivity(w, z).max(axis=1)
    bad = t > PASSIVE_SIGMA
    bad[:w.size] |= (z < ZETA_MIN * 1.01) & (t[:w.size] > 0)
    if new is not None:
        bad[new] = t[new] > 0
    return np.flatnonzero(bad & np.append(side != 0, np.ones(t.size - w.size, bool)))


def _passive(new, collocated, before: int) -> bool:
    """Whether the last pole of ``new`` is passive and the other terms are no less so than
    the ``before`` terms beyond passive of the state it was added to."""
    j = new[0].size - 1
    bad = _beyond(new, collocated, j)
    return j not in bad and bad.size <= before


def _placed(sel, state, sd, collocated, fixed, before: int):
    """The state with a term held at the passive place of least cost on side ``sd``, the
    other poles but the ``fixed`` ones refitted; None when it is passive nowhere
    (``before``: the terms of ``state`` beyond passive, :func:`_passive`)."""
    w, z, side = state[:3]
    zs = float(np.median(z[side == 0]))
    sn = np.append(side, sd)
    best, wbest = np.inf, None
    for f in oob_grid(sel.fband, sd):
        wn, zn = np.append(w, 2 * np.pi * f), np.append(z, zs)
        if not _passive((wn, zn, sn), collocated, before):
            continue
        cost = sel.prob.evaluate(np.concatenate([np.log(wn), np.log(zn)]))["cost"]
        if cost < best:
            best, wbest = cost, wn
    if wbest is None:
        return None
    only = np.setdiff1d(np.arange(w.size), np.asarray(fixed, int))
    w2, z2, ev2, info2 = sel.fit(wbest, np.append(z, zs), sn, only=only)
    return w2, z2, sn, ev2, info2


def _why_not(sel, new, collocated, before: int) -> str | None:
    """Why the term (last pole) of ``new`` is not kept, else None (``before``: the terms
    beyond passive of the state it was added to)."""
    w, z, side, ev, info = new
    reasons = sel._rejected(w, z, side, info, ev)
    if reasons:
        return "; ".join(f"{w[i] / (2 * np.pi):.4g} Hz {r}" for i, r in reasons.items())
    sig = sel.significance(w, z, ev, side)[-1]
    if sig < 1.0:
        return f"not significant ({sig:.3g} x noise threshold)"
    if not _passive(new, collocated, before):
        return "not passive at a collocated pair once the other poles were refitted"
    return None


def far_terms(sel, state, collocated):
    """The final state of the selection with one more out-of-band term per side where it is
    kept (module notes).

    Parameters
    ----------
    sel : AutoSelection
        The selection (its ``fit``, ``prob``, ``fband``, ``rules``, ``_rejected``,
        ``significance`` and ``log``).
    state : tuple
        ``(w, z, side, ev, info)`` of the final fit.
    collocated : CollocatedResidues or None
        The data at the collocated pairs; None (no pairs): no term is tried.

    Returns
    -------
    tuple
        The new state (``state`` itself when no term is kept).
    """
    if collocated is None or not sel.rules.oob_search or not np.any(state[2] == 0):
        return state
    fixed = []
    for sd in (-1, 1):
        kind = "out-of-band term " + ("below" if sd < 0 else "above")
        before = _beyond(state, collocated).size
        new = _placed(sel, state, sd, collocated, fixed, before)
        if new is None:
            sel.log.append(("not added", float("nan"), float("nan"),
                            f"{kind}: passive nowhere between the edge and the far bound"))
            continue
        why = _why_not(sel, new, collocated, before)
        f, zj = float(new[0][-1] / (2 * np.pi)), float(new[1][-1])
        sel.log.append(("added", f, zj, kind) if why is None else
                       ("not added", f, zj, f"{kind}: {why}"))
        if why is None:
            fixed.append(new[0].size - 1)
            state = new
    return state
