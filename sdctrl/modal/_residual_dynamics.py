"""Residual dynamics of a normal-mode model: complex modes kept as they are (thesis 3.3).

:func:`sdctrl.normal_modes` turns the in-band identified poles into normal modes (properness,
3.40-3.44).  What cannot be made a normal mode -- poles fitted outside the band to absorb
out-of-band modes (one pole may stand for several modes, its residue is not the dyad of a
collocated mode), or modes whose properness cannot be enforced (no small real root of the
Riccati equation 3.52, too few sensors for the reduced coordinates 3.46-3.47), and the
significant improper part of an in-band residue (the identified residue minus the proper
normal mode's at the same pole) -- stays a complex-mode term
``R_j / (s - lambda_j) + conj(R_j) / (s - conj(lambda_j))`` (3.7) in a :class:`ResidualDynamics`
block.  The block lives at the tested inputs and outputs (it has no FE shapes): a model's FRF and
state-space form add it where the model's sensor and actuator labels match the block's, realised in
the real 2x2-block form (3.26)-(3.33) (:func:`sdctrl._lib.statespace.complex_blocks`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.statespace import complex_blocks
from sdctrl._lib.validate import as_array, check_labels, readonly

__all__ = ["ResidualDynamics"]


@dataclass(frozen=True, eq=False)
class ResidualDynamics(FrozenState):
    """Complex-mode terms a normal-mode model carries as they are (3.7), at the tested I/O.

    Parameters
    ----------
    poles : array_like, shape (m,), complex
        Poles (rad/s), upper half-plane (``Im > 0``).
    residues : array_like, shape (m, ns, na), complex
        Displacement residues at the tested sensors and actuators.
    sensors, actuators : sequence of str
        Labels of the tested outputs and inputs the residues belong to; a model adds the
        block where its own labels match them.
    reasons : sequence of str, shape (m,)
        Why each pole is not a normal mode (e.g. ``"out of band"``, the Riccati failure), or
        ``"improper part: ..."`` for the part of a mode's residue its normal mode does not
        reproduce (that pole is also a normal mode).
    source : array_like of int, shape (m,), optional
        Index of each pole in the complex-mode model it came from.
    pole_std : array_like, shape (m,), complex, optional
        One standard deviation of each pole's real part (in ``.real``) and imaginary part
        (in ``.imag``), rad/s, from the identification's statistics (3.56); NaN where the
        data do not determine it.
    residue_std : array_like, shape (m, ns, na), complex, optional
        One standard deviation of the real (``.real``) and imaginary (``.imag``) part of
        each residue entry, both parts of (3.58); NaN where undetermined.

    Attributes
    ----------
    frequency : ndarray, shape (m,)
        ``|lambda| / 2 pi`` in Hz.
    """

    poles: np.ndarray
    residues: np.ndarray
    sensors: tuple[str, ...] | None = None
    actuators: tuple[str, ...] | None = None
    reasons: tuple[str, ...] = ()
    source: np.ndarray | None = None
    pole_std: np.ndarray | None = None
    residue_std: np.ndarray | None = None

    def __post_init__(self):
        lam = as_array(self.poles, "poles", ndim=1, dtype=complex)
        m = lam.size
        if np.any(lam.imag <= 0):
            raise ValueError("poles must lie in the upper half-plane (Im > 0), rad/s")
        R = as_array(self.residues, "residues", ndim=3, dtype=complex)
        if R.shape[0] != m:
            raise ValueError(f"residues must have shape (m={m}, ns, na), got {R.shape}")
        reasons = tuple(self.reasons) if self.reasons else ("",) * m
        if len(reasons) != m or not all(isinstance(r, str) for r in reasons):
            raise ValueError(f"reasons must hold one string per pole (m={m})")
        sets = object.__setattr__
        sets(self, "poles", readonly(lam))
        sets(self, "residues", readonly(R))
        sets(self, "sensors", check_labels(self.sensors, R.shape[1], "sensors", "s"))
        sets(self, "actuators", check_labels(self.actuators, R.shape[2], "actuators", "a"))
        sets(self, "reasons", reasons)
        if self.source is not None:
            src = np.asarray(self.source)
            if src.shape != (m,) or (m and not np.issubdtype(src.dtype, np.integer)):
                raise ValueError(f"source must hold one integer index per pole (m={m})")
            sets(self, "source", readonly(src.astype(int)))
        for name, shape in (("pole_std", (m,)), ("residue_std", R.shape)):
            v = getattr(self, name)
            if v is None:
                continue
            v = as_array(v, name, dtype=complex, finite=False)
            if v.shape != shape or np.any(v.real < 0) or np.any(v.imag < 0):
                raise ValueError(f"{name} must hold non-negative standard deviations (or NaN) "
                                 f"of shape {shape}, got shape {v.shape}")
            sets(self, name, readonly(v))

    @property
    def m(self) -> int:
        """Number of complex poles in the block."""
        return self.poles.size

    @property
    def frequency(self) -> np.ndarray:
        """Undamped natural frequencies ``|lambda| / 2 pi`` (Hz)."""
        return np.abs(self.poles) / (2 * np.pi)

    def transposed(self) -> ResidualDynamics:
        """The block of the transposed test (reciprocity): residues ``R_j^T``, labels swapped.

        Returns
        -------
        ResidualDynamics
        """
        return ResidualDynamics(self.poles.copy(), np.swapaxes(self.residues, 1, 2).copy(),
                                sensors=self.actuators, actuators=self.sensors,
                                reasons=self.reasons,
                                source=None if self.source is None else self.source.copy(),
                                pole_std=self.pole_std,
                                residue_std=None if self.residue_std is None
                                else np.swapaxes(self.residue_std, 1, 2).copy())

    def placed(self, sensors, actuators, std: bool = False) -> np.ndarray:
        """Residues placed on a model's I/O by label, shape (m, len(sensors), len(actuators)).

        Parameters
        ----------
        sensors, actuators : sequence of str
            The model's labels; entries with no label of the block get zeros.
        std : bool
            Place :attr:`residue_std` instead (zeros when the block has none).

        Returns
        -------
        ndarray, complex
        """
        rs = {lab: i for i, lab in enumerate(self.sensors)}
        ra = {lab: i for i, lab in enumerate(self.actuators)}
        out = np.zeros((self.m, len(sensors), len(actuators)), complex)
        si = [(i, rs[s]) for i, s in enumerate(sensors) if s in rs]
        ai = [(i, ra[a]) for i, a in enumerate(actuators) if a in ra]
        src = self.residue_std if std else self.residues
        if si and ai and src is not None:
            mi, bi = np.array(si).T
            mj, bj = np.array(ai).T
            out[:, mi[:, None], mj[None, :]] = src[:, bi[:, None], bj[None, :]]
        return out

    def frf_array(self, s, sensors, actuators) -> np.ndarray:
        """Displacement FRF of the block at Laplace points ``s`` (rad/s) on a model's I/O.

        Parameters
        ----------
        s : ndarray, shape (nw,), complex
            ``j w`` (rad/s).
        sensors, actuators : sequence of str
            The model's labels.

        Returns
        -------
        ndarray, shape (nw, ns, na), complex
        """
        R = self.placed(sensors, actuators)
        g = 1.0 / (s[:, None] - self.poles[None, :])
        gc = 1.0 / (s[:, None] - self.poles.conj()[None, :])
        return np.einsum("wn,nij->wij", g, R) + np.einsum("wn,nij->wij", gc, R.conj())

    def realisation(self, sensors, actuators):
        """Real 2x2-block form (3.26)-(3.33) on a model's I/O: ``A, B, C, states``.

        Parameters
        ----------
        sensors, actuators : sequence of str
            The model's labels.

        Returns
        -------
        A, B, C : ndarray
            Displacement output, no feedthrough (the terms are strictly proper).
        states : list of str
            ``r{j}_{k}``, ``dr{j}_{k}`` per dyad ``k`` of pole ``j``.
        """
        A, B, C, states = complex_blocks(self.poles, self.placed(sensors, actuators))
        return A, B, C, ["r" + st[1:] if st[0] == "x" else "dr" + st[2:] for st in states]
