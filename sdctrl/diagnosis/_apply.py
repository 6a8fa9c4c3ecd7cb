"""Corrected models: an effect applied to a model, and the delayed model of a measurement lag.

Physical effects are applied as the thesis does for hybrid models (5.2)-(5.4): the
modification's load shape ``b`` gets its static correction (4.23) appended to the model as
quasi-static modes -- shape ``psi``, stiffness ``psi^T K psi``, a nominal mass placing them
at :data:`QS_FACTOR` times the band top (2.20)-(2.22), so that they only act statically in
the band and leave the nominal prediction unchanged -- then the change
``(S^T b) D (S^T b)^T`` is added to the modal matrices and the model is re-diagonalised
(4.17).  A resonator adds its own coordinate.  The result is an ordinary
:class:`~sdctrl.NormalModeModel` (or hybrid model) with ``.frf`` and ``.to_statespace``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["QS_FACTOR", "DelayedModel", "apply_effect"]

#: quasi-static correction modes sit at this many times the band top
QS_FACTOR = 30.0
#: damping ratio of the quasi-static correction modes
QS_DAMPING = 0.1
#: largest relative error of the Pade approximation of a delay at the band top
PADE_TOL = 1e-3


@dataclass(frozen=True, eq=False)
class DelayedModel:
    """A model whose measurements lag by ``tau``: ``H(j w) exp(-j w tau)``.

    Parameters
    ----------
    model : NormalModeModel or ComplexModeModel
        The undelayed model.
    tau : float
        Delay (s).
    fmax : float
        Highest frequency (Hz) where :meth:`to_statespace` must be accurate (Pade order).
    """

    model: object
    tau: float
    fmax: float

    def __post_init__(self):
        if not hasattr(self.model, "frf"):
            raise TypeError("model must be a model with .frf")
        for name in ("tau", "fmax"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or (name == "fmax" and v <= 0):
                raise ValueError(f"{name} must be finite{' and positive' * (name == 'fmax')}")
            object.__setattr__(self, name, v)

    def __repr__(self) -> str:
        return f"DelayedModel({self.model!r}, tau={self.tau:.4g} s)"

    @property
    def sensors(self) -> tuple:
        """Output labels."""
        return self.model.sensors

    @property
    def actuators(self) -> tuple:
        """Input labels."""
        return self.model.actuators

    @property
    def ns(self) -> int:
        """Number of sensors."""
        return len(self.model.sensors)

    @property
    def na(self) -> int:
        """Number of actuators."""
        return len(self.model.actuators)

    def frf(self, freq, quantity: str = "displacement"):
        """FRF of the model times ``exp(-j w tau)``.

        Parameters
        ----------
        freq : array_like
            Frequencies in Hz.
        quantity : {"displacement", "velocity", "acceleration"}
            Measured quantity.

        Returns
        -------
        FRF
        """
        from sdctrl.data._frf import FRF

        out = self.model.frf(freq, quantity)
        lag = np.exp(-2j * np.pi * out.freq * self.tau)
        return FRF(out.freq, out.H * lag[:, None, None], quantity=out.quantity,
                   sensors=out.sensors, actuators=out.actuators, collocated=out.collocated)

    def pade_order(self) -> int:
        """Smallest Pade order matching the delay to :data:`PADE_TOL` up to ``fmax``.

        Returns
        -------
        int
        """
        import control

        w = 2 * np.pi * self.fmax * np.linspace(0.05, 1.0, 40)
        for n in range(1, 15):
            num, den = control.pade(abs(self.tau), n)
            g = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
            if np.abs(g - np.exp(-1j * w * abs(self.tau))).max() < PADE_TOL:
                return n
        return 15

    def to_statespace(self, quantity: str = "displacement", order: int | None = None):
        """StateSpace of the model in series with a Pade approximation of the delay.

        Parameters
        ----------
        quantity : {"displacement", "velocity", "acceleration"}
            Output quantity.
        order : int, optional
            Pade order (default :meth:`pade_order`); one delay block per input.

        Returns
        -------
        control.StateSpace
            Same signal names as the undelayed model's.

        Notes
        -----
        Close loops on it with :func:`sdctrl.feedback`, which keeps the signal names:
        ``control.feedback`` drops them (its result is named ``u[i]``, ``y[i]``).
        """
        import control

        G = self.model.to_statespace(quantity)
        if self.tau == 0:
            return G
        n = self.pade_order() if order is None else int(order)
        num, den = control.pade(self.tau, n)
        P = control.ss(control.tf(num, den))
        na = G.ninputs
        Ad = np.kron(np.eye(na), P.A)
        Bd = np.kron(np.eye(na), P.B)
        Cd = np.kron(np.eye(na), P.C)
        Dd = np.kron(np.eye(na), P.D)
        ng, nd = G.nstates, Ad.shape[0]
        A = np.block([[G.A, G.B @ Cd], [np.zeros((nd, ng)), Ad]])
        B = np.vstack([G.B @ Dd, Bd])
        C = np.hstack([G.C, G.D @ Cd])
        D = G.D @ Dd
        states = list(G.state_labels) + [f"delay{j}" for j in range(nd)]
        return control.ss(A, B, C, D, inputs=list(G.input_labels),
                          outputs=list(G.output_labels), states=states)


def _full(X, rows, cols, shape):
    out = np.zeros(shape)
    out[np.ix_(rows, cols)] = X
    return out


def _append_mode(model, placed, p):
    """A free normal mode (NormalModeModel) or a complex pole pair (ComplexModeModel)."""
    w, z = p["omega"], p["zeta"]
    ns, na = len(model.sensors), len(model.actuators)
    c = np.zeros(ns)
    c[placed.rows] = p["c"]
    b = np.zeros(na)
    b[placed.cols] = p["b"]
    from sdctrl.identification import ComplexModeModel

    if isinstance(model, ComplexModeModel):
        wd = w * np.sqrt(max(1 - z * z, 1e-12))
        lam = complex(-z * w, wd)
        R = np.outer(c, b) / (2j * wd)
        return model.replace(poles=np.r_[model.poles, lam],
                             residues=np.concatenate([model.residues, R[None]]),
                             in_band=np.r_[model.in_band, True])
    n = model.n
    Om = np.zeros((n + 1, n + 1))
    Om[:n, :n] = model.Omega
    Om[n, n] = w * w
    Ga = np.zeros((n + 1, n + 1))
    Ga[:n, :n] = model.Gamma
    Ga[n, n] = 2 * z * w
    shapes = None if model.shapes is None else np.hstack([model.shapes,
                                                          np.zeros((model.shapes.shape[0], 1))])
    return model.replace(Omega=Om, Gamma=Ga, cphi=np.hstack([model.cphi, c[:, None]]),
                         phib=np.vstack([model.phib, b[None]]), shapes=shapes)


def _augment(model, q, fmax):
    """Quasi-static correction modes (2.20)-(2.22) of a load: shapes ``psi`` (model DOF
    order), stiffness ``psi^T K psi``; the nominal response is kept (``E`` compensated)."""
    psi, Kp, cy, bu = q["psi"], q["Kpsi"], q["cy"], q["bu"]
    d, U = np.linalg.eigh(0.5 * (Kp + Kp.T))
    keep = d > 1e-12 * max(d.max(), 1e-300) if d.size else d > 0
    if not np.any(keep):
        return model, np.zeros((model.n, 0))
    d, U = d[keep], U[:, keep]
    wc = 2 * np.pi * QS_FACTOR * fmax
    scale = wc / np.sqrt(d)                         # 1 / sqrt(mu), mu = kappa / wc^2
    r, n = d.size, model.n
    Om = np.zeros((n + r, n + r))
    Om[:n, :n] = model.Omega
    Om[n:, n:] = wc**2 * np.eye(r)
    Ga = np.zeros((n + r, n + r))
    Ga[:n, :n] = model.Gamma
    Ga[n:, n:] = 2 * QS_DAMPING * wc * np.eye(r)
    V = psi @ U * scale
    E = None if model.E is None else np.array(model.E, float)
    if np.any(bu):
        comp = cy @ U @ np.diag(1 / d) @ U.T @ bu
        E = -comp if E is None else E - comp
    out = model.replace(Omega=Om, Gamma=Ga, cphi=np.hstack([model.cphi, cy @ U * scale]),
                        phib=np.vstack([model.phib, (U.T @ bu) * scale[:, None]]),
                        shapes=np.hstack([model.shapes, V]), E=E)
    return out, (U.T * scale[:, None])


def _lowrank(model, p, fmax):
    """A spring, dashpot or mass on load ``b`` (reanalysis 4.17 with its static modes)."""
    aug, Wq = _augment(model, p["static"], fmax)
    bm = np.vstack([np.asarray(model.shapes).T @ p["b"], Wq @ p["bpsi"]])      # (n + r, k)
    X = bm @ bm.T
    kind, x = p["kind"], p["size"]
    if kind == "resonator":
        return _resonator(aug, bm[:, 0], x, p["omega"], p["zeta"])
    zero = np.zeros_like(X)
    return aug.modified(dmu=x * X if kind == "mass_change" else zero,
                        dGamma=x * X if kind == "added_damper" else zero,
                        dOmega=x * X if kind == "stiffness_change" else zero)


def _resonator(model, bm, m, w, z):
    """A mass ``m`` on a spring ``m w^2`` with a dashpot ``2 z w m`` attached along ``b``."""
    n = model.n
    kr, cr = m * w * w, 2 * z * w * m
    Om = np.zeros((n + 1, n + 1))
    Ga = np.zeros((n + 1, n + 1))
    for X, base, k in ((Om, model.Omega, kr), (Ga, model.Gamma, cr)):
        X[:n, :n] = base + k * np.outer(bm, bm)
        X[:n, n] = X[n, :n] = -k * bm / np.sqrt(m)
        X[n, n] = k / m
    shapes = np.hstack([model.shapes, np.zeros((model.shapes.shape[0], 1))])
    out = model.replace(Omega=Om, Gamma=Ga, cphi=np.hstack([model.cphi,
                                                           np.zeros((model.ns, 1))]),
                        phib=np.vstack([model.phib, np.zeros((1, model.na))]), shapes=shapes)
    return out.modified()


def apply_effect(model, prop, placed):
    """The model with a fitted effect (a proposal of :mod:`.effects` or :mod:`.scan`) added.

    Parameters
    ----------
    model : NormalModeModel, ComplexModeModel or DelayedModel
        Current model.
    prop : dict
        The proposal.
    placed : Placed
        The data (channels of the fitted terms).

    Returns
    -------
    model
        Same kind of model (a DelayedModel after a delay).
    """
    if isinstance(model, DelayedModel):
        if prop["action"] == "delay":
            return DelayedModel(model.model, model.tau + prop["payload"]["tau"], model.fmax)
        return DelayedModel(apply_effect(model.model, prop, placed), model.tau, model.fmax)
    p, act = prop["payload"], prop["action"]
    fmax = float(placed.freq[-1])
    if act == "delay":
        return DelayedModel(model, p["tau"], fmax)
    if act == "residual":
        shape = (len(model.sensors), len(model.actuators))
        X = _full(p["X"], placed.rows, placed.cols, shape)
        old = getattr(model, p["field"])
        return model.replace(**{p["field"]: X if old is None else np.asarray(old) + X})
    if act == "mode":
        return _append_mode(model, placed, p)
    if act == "gamma":
        return model.replace(Gamma=np.asarray(model.Gamma) + p["dGamma"])
    if act == "lowrank":
        return _lowrank(model, p, fmax)
    raise ValueError(f"unknown effect action {act!r}")
