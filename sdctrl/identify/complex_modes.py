"""Complex-mode models (thesis 3.1, parametrisation 3.7) and their MIMO forms (3.2).

``H_d(s) = sum_j [R_j/(s - lambda_j) + R_j^*/(s - lambda_j^*)] + E + F/s^2``
describes the displacement/force response; ``E`` is the residual flexibility of
modes above the band, ``F/s^2`` the residual mass of modes below it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sdctrl._validate import (
    QUANTITY_POWER,
    as_array,
    check_collocated,
    check_freq,
    check_labels,
    check_quantity,
    readonly,
)

__all__ = ["ComplexModeModel"]


@dataclass(frozen=True, eq=False)
class ComplexModeModel:
    """Identified complex-mode model (3.7), displacement/force residues.

    Parameters
    ----------
    poles : array_like, shape (n,)
        Complex poles in rad/s, upper half-plane (Im > 0), stable (Re < 0).
    residues : array_like, shape (n, ns, na)
        Complex residue matrices ``R_j`` of the displacement response.
    E : array_like, shape (ns, na), optional
        Real high-frequency asymptotic term (residual flexibility); zeros by default.
    F : array_like, shape (ns, na), optional
        Real low-frequency asymptotic term, ``F/s^2`` (residual mass); zeros by default.
    in_band : array_like of bool, shape (n,), optional
        False for poles fitted just outside the band to absorb nearby modes.
    cost : float, optional
        Final value of the fitting cost (relative quadratic FRF error).
    sensors, actuators : sequence of str, optional
        Labels of the FRF the model was fitted to.
    collocated : sequence of (int, int), optional
        Collocated (sensor, actuator) pairs of the test.
    band : (float, float), optional
        Frequency band (Hz) of the fit.
    info : dict, optional
        Diagnostics of the fit (iterations, warnings, optimiser).
    """

    poles: np.ndarray
    residues: np.ndarray
    E: np.ndarray | None = None
    F: np.ndarray | None = None
    in_band: np.ndarray | None = None
    cost: float = float("nan")
    sensors: tuple[str, ...] | None = None
    actuators: tuple[str, ...] | None = None
    collocated: tuple[tuple[int, int], ...] = ()
    band: tuple[float, float] | None = None
    info: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        lam = as_array(self.poles, "poles", ndim=1, dtype=complex)
        n = lam.size
        R = as_array(self.residues, "residues", ndim=3, dtype=complex)
        if R.shape[0] != n:
            raise ValueError(f"residues must have shape (n={n}, ns, na), got {R.shape}")
        ns, na = R.shape[1:]
        if np.any(lam.imag <= 0):
            raise ValueError("poles must lie in the upper half-plane (Im > 0), one per mode")
        if np.any(lam.real >= 0):
            raise ValueError("poles must be stable (Re < 0)")
        E = np.zeros((ns, na)) if self.E is None else as_array(self.E, "E", shape=(ns, na))
        F = np.zeros((ns, na)) if self.F is None else as_array(self.F, "F", shape=(ns, na))
        if self.in_band is None:
            ib = np.ones(n, bool)
        else:
            ib = np.array(self.in_band, dtype=bool, copy=True).reshape(-1)
            if ib.size != n:
                raise ValueError(f"in_band must have {n} entries, got {ib.size}")
        sensors = check_labels(self.sensors, ns, "sensors", "s")
        actuators = check_labels(self.actuators, na, "actuators", "a")
        sets = object.__setattr__
        sets(self, "poles", readonly(lam))
        sets(self, "residues", readonly(R))
        sets(self, "E", readonly(E))
        sets(self, "F", readonly(F))
        sets(self, "in_band", readonly(ib))
        sets(self, "cost", float(self.cost))
        sets(self, "sensors", sensors)
        sets(self, "actuators", actuators)
        sets(self, "collocated", check_collocated(self.collocated, ns, na, "collocated",
                                                  sensors, actuators))
        sets(self, "info", dict(self.info))

    # --- sizes and modal data -------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of modes (pole pairs)."""
        return self.poles.size

    @property
    def ns(self) -> int:
        """Number of sensors."""
        return self.residues.shape[1]

    @property
    def na(self) -> int:
        """Number of actuators."""
        return self.residues.shape[2]

    @property
    def frequency(self) -> np.ndarray:
        """Undamped natural frequencies ``|lambda| / 2 pi`` (Hz)."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping(self) -> np.ndarray:
        """Damping ratios ``-Re(lambda) / |lambda|``."""
        return -self.poles.real / np.abs(self.poles)

    def replace(self, **changes) -> ComplexModeModel:
        """Copy with some fields changed (validated again)."""
        kw = {k: getattr(self, k) for k in ("poles", "residues", "E", "F", "in_band", "cost",
                                            "sensors", "actuators", "collocated", "band",
                                            "info")}
        kw.update(changes)
        return ComplexModeModel(**kw)

    def frf(self, freq, quantity: str = "displacement"):
        """FRF of the model (3.7) at ``freq`` (Hz) for ``quantity``.

        Parameters
        ----------
        freq : array_like
            Frequencies in Hz.
        quantity : {"displacement", "velocity", "acceleration"}

        Returns
        -------
        FRF
        """
        from sdctrl.frf import FRF

        f = check_freq(freq, "freq")
        q = check_quantity(quantity, "quantity")
        s = 2j * np.pi * f
        H = frf_array(self.poles, self.residues, self.E, self.F, s)
        H = H * (s ** QUANTITY_POWER[q])[:, None, None]
        return FRF(f, H, quantity=q, sensors=self.sensors, actuators=self.actuators,
                   collocated=self.collocated)


def frf_array(poles, residues, E, F, s) -> np.ndarray:
    """Displacement FRF (ns x na per line) of (3.7) at Laplace points ``s`` (rad/s)."""
    g = 1.0 / (s[:, None] - poles[None, :])             # (nf, n)
    gc = 1.0 / (s[:, None] - poles.conj()[None, :])
    H = np.einsum("wn,nij->wij", g, residues) + np.einsum("wn,nij->wij", gc, residues.conj())
    H = H + E[None]
    if F is not None and np.any(F):
        H = H + F[None] / (s[:, None, None] ** 2)
    return H
