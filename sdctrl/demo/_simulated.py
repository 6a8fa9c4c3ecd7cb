"""The simulated test of the story and its truth (step 1 of ``sdctrl demo``).

The built-in testbed stands for the lab structure: :func:`simulate_test` makes the
measured FRFs of any FE model as :func:`sdctrl.testbed_frf` does (also the second test of
the diagnosis step, on a changed structure), :func:`exact_poles` the truth the identified
poles are compared with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from sdctrl.report import Check, modes_table
from sdctrl.testbeds._measurement_noise import relative_noise

__all__ = ["SimulatedTest", "exact_poles", "simulate_test", "simulated_testbed_test"]


def exact_poles(fe, band) -> np.ndarray:
    """Exact complex poles (rad/s, Im > 0) of an FE model with frequency in ``band`` (Hz).

    The damped eigenproblem of the full model (state-space pencil, dense): the truth the
    identified poles are compared with.

    Parameters
    ----------
    fe : FEModel
        Model with its damping matrix ``C``.
    band : (float, float)
        Frequency range (Hz).

    Returns
    -------
    ndarray
        Sorted by frequency.
    """
    N = fe.N
    M, K = _dense(fe.M), _dense(fe.K)
    C = _dense(fe.C) if fe.C is not None else np.zeros((N, N))
    A = np.block([[np.zeros((N, N)), np.eye(N)], [-K, -C]])
    B = np.block([[np.eye(N), np.zeros((N, N))], [np.zeros((N, N)), M]])
    lam = sla.eig(A, B, right=False)
    lam = lam[np.isfinite(lam) & (lam.imag > 0)]
    f = np.abs(lam) / (2 * np.pi)
    lam = lam[(f > band[0]) & (f < band[1])]
    return lam[np.argsort(np.abs(lam))]


def _dense(A) -> np.ndarray:
    return A.toarray() if hasattr(A, "toarray") else np.asarray(A, dtype=float)


def simulate_test(fe, freq, noise: float, seed, sensors, shakers, fmax: float):
    """Simulated acceleration test of an FE model, as :func:`sdctrl.testbed_frf` makes it.

    Modes up to ``fmax`` with the full projected damping and static correction modes for
    the shakers, then ``H (1 + noise e)`` with ``e`` complex standard normal.

    Parameters
    ----------
    fe : FEModel
        The structure tested.
    freq : array_like
        Frequency lines (Hz).
    noise : float
        Relative noise level.
    seed : int
        Noise seed.
    sensors, shakers : sequence of str
        DOF labels.
    fmax : float
        Highest modal frequency kept (Hz).

    Returns
    -------
    FRF
    """
    from sdctrl.data._frf import FRF

    f, _ = fe.modes(min(fe.N, 60))
    n = max(int(np.searchsorted(f, fmax)), 16)
    model = fe.normal_mode_model(list(shakers), list(sensors), n, static=True,
                                 static_damping="projected")
    freq = np.asarray(freq, dtype=float)
    H = model.frf(freq, "acceleration").H
    H = relative_noise(H, noise, seed)
    return FRF(freq, H, "acceleration", sensors=list(sensors), actuators=list(shakers),
               collocated=[(i, i) for i in range(len(shakers))])


# --- step 1: the simulated test ------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SimulatedTest:
    """The simulated modal test of the built-in testbed and its truth.

    Parameters
    ----------
    frf : FRF
        Measured (simulated, noisy) acceleration FRFs.
    fe : FEModel
        The true structure.
    noise : float
        Relative noise level.
    seed : int
        Noise seed.
    poles : ndarray
        Exact complex poles of the structure in the band (rad/s).
    fe_hz : ndarray
        Undamped frequencies (Hz) of the structure's modes in the band.
    Gamma : ndarray
        The structure's modal damping matrix projected on those modes (rad/s).
    cphi : ndarray
        Their mass-normalised shapes at the sensors.
    """

    frf: object
    fe: object
    noise: float
    seed: int
    poles: np.ndarray
    fe_hz: np.ndarray
    Gamma: np.ndarray
    cphi: np.ndarray

    @property
    def summary(self) -> str:
        """One line."""
        f = self.frf
        return (f"{len(f.sensors)} sensors x {len(f.actuators)} shakers, {f.freq.size} lines "
                f"{f.freq[0]:g}-{f.freq[-1]:g} Hz, {100 * self.noise:g}% noise; "
                f"{self.poles.size} modes in the band")

    def checks(self) -> list[Check]:
        """No key number to check: this is the truth."""
        return []

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        return {"noise": self.noise, "seed": self.seed, "lines": int(self.frf.freq.size),
                "true_frequency_hz": np.abs(self.poles) / (2 * np.pi),
                "true_damping": -self.poles.real / np.abs(self.poles)}

    def section(self, doc) -> None:
        """Write the report section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        """
        from sdctrl import plot

        f, fe = self.frf, self.fe
        s = doc.section("test", "The structure and its simulated test")
        s.paragraph(
            f"The built-in testbed (`sd.testbed()`): a suspended truss carrying three plates "
            f"on flexible posts, {fe.N} DOFs, Rayleigh damping plus three discrete dashpots "
            f"(non-proportional damping). Its simulated test (`sd.testbed_frf`): "
            f"{len(f.sensors)} accelerometers x {len(f.actuators)} shakers, {f.freq.size} "
            f"lines from {f.freq[0]:g} to {f.freq[-1]:g} Hz, {100 * self.noise:g}% complex "
            f"multiplicative noise (seed {self.seed}); each shaker has a collocated sensor.")
        s.paragraph(f"True modes in the band (exact damped eigenvalues of the FE model): "
                    f"{self.poles.size}.")
        s.markdown(modes_table(self.poles))
        f_fe, _ = fe.modes(12)
        below = int(np.sum(f_fe <= f.freq[0]))        # suspension modes under the band
        idx = [below, below + 2, below + 3]             # modes 1, 3, 4 of the band
        names = [f"mode {m - below + 1}: {f_fe[m]:.2f} Hz undamped" for m in idx]
        pair = np.sort(np.abs(self.poles) / (2 * np.pi))[2:4]
        s.figure(plot.mode_shapes(fe, modes=idx, names=names), "Modes 1, 3 and 4 of the band, "
                 "numbered as in the table (3 and 4 are the close pair coupled by the plate-A "
                 "damper). The titles give the undamped natural frequencies of the FE modes, "
                 "the table the frequencies |lambda|/2pi of the damped poles: the damping "
                 f"coupling moves the close pair's poles ({pair[0]:.2f} and {pair[1]:.2f} Hz) "
                 f"away from its undamped frequencies ({f_fe[idx[1]]:.2f} and "
                 f"{f_fe[idx[2]]:.2f} Hz).", "true_modes")


def simulated_testbed_test(noise: float = 0.01, seed: int = 0, n: int = 1000):
    """Step 1: the simulated test of the built-in testbed and its truth.

    Parameters
    ----------
    noise : float
        Relative noise.
    seed : int
        Noise seed.
    n : int
        Frequency lines.

    Returns
    -------
    SimulatedTest
    """
    from sdctrl.testbeds._truss import SENSORS, TESTBED_BAND, testbed, testbed_frf

    fe = testbed()
    frf = testbed_frf(noise=noise, seed=seed, n=n)
    poles = exact_poles(fe, TESTBED_BAND)
    f, phi = fe.modes(30)
    keep = (f > TESTBED_BAND[0]) & (f < TESTBED_BAND[1])
    phi = phi[:, keep]
    C = fe.C
    Gamma = phi.T @ (C @ phi)
    cphi = phi[fe.dof_index(list(SENSORS))]
    return SimulatedTest(frf, fe, float(noise), int(seed), poles, f[keep],
                         0.5 * (Gamma + Gamma.T), cphi)
