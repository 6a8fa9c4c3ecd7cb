"""Hybrid predictions on a member of the family of test structures (issue 22): a D-strut on
the bar that carries the most strain energy of the in-band modes, a broken strut, an untested
shaker, the closed-loop band RMS of the D-strut design -- each against the truth and against
the deliberately wrong FE model.

The bar's axial stiffness is ``s^T K_e s / (s^T s)^2`` (``K_e`` the element's stiffness,
``s`` the strut shape); the D-strut keeps 0.6 of it with a dashpot that would add 5% damping
to the in-band mode it strains most (``kv (s^T phi)^2 / (2 w) = 0.05``); the broken strut
loses the whole bar.  Truths: FRFs by the FE model's direct solve; RMS from the FE model's
modes up to 60 with the static correction of the shakers and of the strut, closed by the
strut loop (5.3)-(5.4).
"""

import warnings
from dataclasses import dataclass

import numpy as np

import sdctrl as sd
from sdctrl.closedloop._loops import rms
from sdctrl.updating._costs import logls


@dataclass(frozen=True)
class Strut:
    a: str
    b: str
    k_bar: float
    kv: float


def pick_bar(st, true) -> Strut:
    """The bar with the most strain energy in the in-band modes of the true structure."""
    lo, hi = st.band
    f, phi = true.modes(40)
    sel = (f > lo) & (f < hi)
    w = 2 * np.pi * f[sel]
    best = None
    for a, b in true.members():
        try:
            s = true.strut(a, b)
        except ValueError:                      # a grounded element
            continue
        Ke, _ = true.member_matrices(elements=[(a, b)])
        kb = float((s.T @ (Ke @ s)).item()) / float((s.T @ s).item()) ** 2
        if kb <= 0:
            continue
        sp = (s.T @ phi[:, sel]).ravel()
        score = float(np.sum(kb * sp ** 2 / w ** 2))
        if best is None or score > best[0]:
            k = int(np.argmax(sp ** 2 / w ** 2))
            best = (score, Strut(a, b, kb, 2 * 0.05 * w[k] / sp[k] ** 2))
    return best[1]


def with_strut(fe, s, kp, kv):
    C = fe.C if fe.C is not None else 0 * fe.K
    return sd.FEModel(fe.M, fe.K + kp * s @ s.T, C + kv * s @ s.T, dofs=fe.dofs)


def fe_loop(fe, s, shakers, sensors, kp, kv, n=60):
    m = fe.normal_mode_model(np.hstack([fe.point(list(shakers)), s]),
                             fe.point(list(sensors)).T, n, static=True,
                             static_damping="projected")
    m = sd.NormalModeModel(m.Omega, m.Gamma, m.cphi, m.phib[:, :len(shakers)],
                           shapes=m.shapes, dofs=m.dofs)
    return m.with_feedback(s, s.T, kp=kp, kv=kv)


def total_rms(model, band) -> float:
    return float(np.linalg.norm(rms(model.to_statespace("acceleration"), band)))


@dataclass(frozen=True)
class Figures:
    """logLS of the nominal hybrid and the identified model; ratios wrong FE / hybrid."""
    nominal: float
    nm: float
    dstrut: float
    broken: float
    shaker: float
    rms_hybrid: float
    rms_fe: float


def figures(st, nm, h, h_minus, n=300) -> Figures:
    """The figures of a hybrid ``h`` (all shakers) and ``h_minus`` (the last one left out)."""
    true, wrong = st.fe(), st.wrong()
    SH, SE = list(st.shakers), list(st.sensors)
    freq = np.linspace(*st.band, n)
    ref = true.frf(freq, SH, SE, "acceleration")
    bar = pick_bar(st, true)
    s = wrong.strut(bar.a, bar.b)
    ratios = []
    for kp, kv in ((-0.4 * bar.k_bar, bar.kv), (-bar.k_bar, 0.0)):
        rf = with_strut(true, s, kp, kv).frf(freq, SH, SE, "acceleration")
        ef = logls(with_strut(wrong, s, kp, kv).frf(freq, SH, SE, "acceleration"), rf)
        ratios.append(ef / logls(h.with_feedback(s, s.T, kp=kp, kv=kv).frf(freq,
                                                                           "acceleration"), rf))
    u = SH[-1]
    r6 = true.frf(freq, [u], SE, "acceleration")
    e6 = logls(wrong.frf(freq, [u], SE, "acceleration"), r6)
    shaker = e6 / logls(h_minus.with_io(b=[u]).frf(freq, "acceleration"), r6)
    kp, kv = -0.4 * bar.k_bar, bar.kv
    r_true = total_rms(fe_loop(true, s, SH, SE, kp, kv), st.band)
    r_fe = total_rms(fe_loop(wrong, s, SH, SE, kp, kv), st.band)
    r_h = total_rms(h.with_feedback(s, s.T, kp=kp, kv=kv), st.band)
    return Figures(logls(h.frf(freq, "acceleration"), ref), logls(nm.frf(freq, "acceleration"),
                                                                  ref),
                   ratios[0], ratios[1], shaker, abs(r_h / r_true - 1), abs(r_fe / r_true - 1))


def identified_models(st, noise, weighting=None):
    """The normal-mode models of ``st``'s test (seed 1, 400 lines) with every shaker and
    without the last one, from ``sd.identify``'s default fit or the given ``weighting``."""
    SH = list(st.shakers)
    frf = st.frf(n=400, noise=noise, seed=1)
    kw = {"progress": False} if weighting is None else {"progress": False,
                                                        "weighting": weighting}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(sd.identify(frf, **kw), std=False)
        nm_minus = sd.normal_modes(sd.identify(frf.select(actuators=SH[:-1]), **kw),
                                   std=False)
    return nm, nm_minus
