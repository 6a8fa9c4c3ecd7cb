"""Measured FRFs placed on a model: the lines, the displacement/force data and the channels.

The logLS cost of two FRFs of one quantity equals that of their displacement forms (the
``(j w)^k`` factors cancel in ``Log H_M - Log H_I``), so the diagnosis works on
displacement/force responses throughout.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sdctrl._lib.validate import QUANTITY_POWER, check_band
from sdctrl.diagnosis._apply import DelayedModel
from sdctrl.diagnosis._lowrank import Resolvent

__all__ = ["Placed", "place"]


@dataclass(frozen=True, eq=False)
class Placed:
    """Measured FRFs on the lines and channels of a model.

    Parameters
    ----------
    frf : FRF
        The data (restricted to the band).
    Hd : ndarray, shape (nf, ns, na)
        Displacement/force data (a known delay removed: see :meth:`undelayed`).
    rows : ndarray of int, shape (ns,)
        Model sensor of each data sensor.
    cols : ndarray of int, shape (na,)
        Model actuator of each data actuator.
    """

    frf: object
    Hd: np.ndarray
    rows: np.ndarray
    cols: np.ndarray

    @property
    def freq(self) -> np.ndarray:
        """Lines (Hz)."""
        return self.frf.freq

    @property
    def omega(self) -> np.ndarray:
        """Lines (rad/s)."""
        return 2 * np.pi * self.frf.freq

    @property
    def s(self) -> np.ndarray:
        """Laplace points ``j w``."""
        return 1j * self.omega

    @property
    def sensors(self) -> tuple:
        """Data sensor labels."""
        return self.frf.sensors

    @property
    def actuators(self) -> tuple:
        """Data actuator labels."""
        return self.frf.actuators

    @property
    def n_entries(self) -> int:
        """Number of complex entries (lines x sensors x actuators)."""
        return int(self.Hd.size)

    def response(self, model) -> np.ndarray:
        """Displacement response of a model on the lines and data channels.

        Parameters
        ----------
        model : NormalModeModel, ComplexModeModel or DelayedModel
            Any model with ``frf(freq, quantity)``.

        Returns
        -------
        ndarray, shape (nf, ns, na)
        """
        H = model.frf(self.freq, "displacement").H
        return H[:, self.rows][:, :, self.cols]

    def fast_response(self, model) -> np.ndarray:
        """:meth:`response` through one complex-mode factorisation of a coupled model
        (:func:`_coupled_response`), for the loops that evaluate many variants of a model
        (the joint refit, the finite differences of the effects' standard deviations); equal
        to :meth:`response` to round-off amplified by the modes' conditioning (below 1e-9
        relative on the testbeds).  Errors that are reported use :meth:`response`.

        Parameters
        ----------
        model : NormalModeModel, ComplexModeModel or DelayedModel
            Any model with ``frf(freq, quantity)``.

        Returns
        -------
        ndarray, shape (nf, ns, na)
        """
        if isinstance(model, DelayedModel):
            return self.fast_response(model.model) * self.lag(model)[:, None, None]
        H = _coupled_response(model, self)
        return self.response(model) if H is None else H

    def lag(self, model) -> np.ndarray | None:
        """The delay factor ``exp(-j w tau)`` per line of a :class:`DelayedModel`; None for an
        undelayed model.

        Parameters
        ----------
        model : model
            Any model.

        Returns
        -------
        ndarray, shape (nf,), complex, or None
        """
        if not isinstance(model, DelayedModel):
            return None
        return np.exp(-1j * self.omega * model.tau)

    def static_part(self, model) -> np.ndarray:
        """``E + F / s^2`` of a normal-mode model on the data channels, shape (nf, ns, na).

        Parameters
        ----------
        model : NormalModeModel
            The model.

        Returns
        -------
        ndarray
        """
        out = np.zeros(self.Hd.shape, complex)
        if model.E is not None:
            out = out + np.asarray(model.E)[self.rows][:, self.cols]
        if getattr(model, "F", None) is not None:
            out = out + np.asarray(model.F)[self.rows][:, self.cols] / self.s[:, None, None] ** 2
        return out

    def undelayed(self, tau: float) -> Placed:
        """The data with a measurement delay ``tau`` (s) removed (``Hd exp(j w tau)``).

        Parameters
        ----------
        tau : float
            Delay (s).

        Returns
        -------
        Placed
        """
        if tau == 0:
            return self
        return replace(self, Hd=self.Hd * np.exp(1j * self.omega * tau)[:, None, None])


def _coupled_response(model, placed):
    """``cphi Z(s)^-1 phib + E + F / s^2`` (2.15) of a normal-mode model with coupled
    ``Omega``/``Gamma`` (effects applied, non-proportional damping) on the data channels only,
    through one complex-mode factorisation of ``Z`` (:class:`._lowrank.Resolvent`) instead of
    one ``n x n`` solve per line: the joint refit and the effects' standard deviations
    evaluate it at every step of their finite differences.  None when the model is not a
    plain :class:`NormalModeModel` (or has uncoupled matrices, residual dynamics, or a
    factorisation that does not hold): its own ``frf`` is then used."""
    from sdctrl.modal._normal_model import NormalModeModel

    if type(model) is not NormalModeModel or model.residual is not None:
        return None
    Om, Ga = np.asarray(model.Omega), np.asarray(model.Gamma)
    if not (np.count_nonzero(Ga - np.diag(np.diag(Ga)))
            or np.count_nonzero(Om - np.diag(np.diag(Om)))):
        return None                     # diagonal: the model's own frf is the fast path
    R = Resolvent.of(Om, Ga)
    if R.lam is None:
        return None
    s = placed.s
    H = R.transfer(s, np.asarray(model.cphi)[placed.rows].T,
                   np.asarray(model.phib)[:, placed.cols])
    return _plus_static(H, model, placed)


def _plus_static(H, model, placed):
    """``H + E + F / s^2`` on the data channels; None when not finite (the model's own
    ``frf`` then raises its error)."""
    if model.E is not None:
        H = H + np.asarray(model.E)[placed.rows][:, placed.cols]
    if model.F is not None:
        H = H + np.asarray(model.F)[placed.rows][:, placed.cols] / placed.s[:, None, None] ** 2
    return H if np.all(np.isfinite(H)) else None


def _match(labels, model_labels, what):
    model_labels = list(model_labels)
    idx = []
    for lab in labels:
        if lab not in model_labels:
            raise ValueError(f"frf: {what} {lab!r} is not a {what} of the model (model "
                             f"{what}s: {model_labels[:6]}...)")
        idx.append(model_labels.index(lab))
    return np.asarray(idx, int)


def place(model, frf, band=None) -> Placed:
    """Place measured FRFs on a model by their sensor and actuator labels.

    Parameters
    ----------
    model : NormalModeModel or ComplexModeModel
        The model; its labels must include the data's.
    frf : FRF
        The data.
    band : (float, float), optional
        Band (Hz); default all lines.

    Returns
    -------
    Placed

    Raises
    ------
    ValueError
        Unknown labels, fewer than 5 lines, or zero responses (the logLS takes logarithms).
    """
    data = frf
    if band is not None:
        lo, hi = check_band(band, "band")
        data = frf.band(lo, hi)
    if data.freq.size < 5:
        raise ValueError(f"frf must have at least 5 lines in the band, got {data.freq.size}")
    rows = _match(data.sensors, model.sensors, "sensor")
    cols = _match(data.actuators, model.actuators, "actuator")
    w = 2 * np.pi * data.freq
    H = data.H / ((1j * w) ** QUANTITY_POWER[data.quantity])[:, None, None]
    if not np.all(np.isfinite(H)) or not np.all(np.abs(H) > 0):
        raise ValueError("frf: the responses must be finite and non-zero on every line (the "
                         "logLS cost takes their logarithm)")
    H.setflags(write=False)
    return Placed(data, H, rows, cols)
