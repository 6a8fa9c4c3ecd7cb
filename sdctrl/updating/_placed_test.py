"""The measured side of an FE update: the test placed on the FE model, the modes identified
from it, and the measurement's own error level (thesis 4.1, 4.2.1).

- :func:`place_test` ties an FRF to an FE model through its sensor/actuator labels (DOF
  labels of the model) and keeps the band's lines as displacement/force, the form the
  reduced models predict (the logLS cost (3.12) of two FRFs of one quantity equals that of
  their displacement forms: the ``(j w)^k`` factors cancel);
- :func:`measured_modes` gives the normal modes of the data (frequency, damping, observability
  ``(c phi)_ID``) for the frequency/MAC criteria (4.8)-(4.9) and the damping estimated
  from data: an identified model given by the user, else :func:`sdctrl.identify` then
  :func:`sdctrl.normal_modes` (full ``Gamma``) when the test has collocated pairs;
- :func:`error_level` is the expected logLS cost of the measurement against the truth:
  ``mean((1 - coherence) / (2 n_averages))`` from the coherence (3.59) (the log-magnitude
  takes half the variance of a complex relative error) when it measures the noise (not one
  up to round-off: :func:`~sdctrl.data._coherence.measured_coherence`), else the misfit of an
  identified model, robustly: ``median(r^2) / 0.455`` of its log-magnitude residuals ``r`` (the
  median of a chi-square variable of one degree of freedom), so that a locally poor fit
  (a missed mode) does not pass for noise.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from sdctrl._lib.validate import QUANTITY_POWER, check_band
from sdctrl.data._coherence import measured_coherence
from sdctrl.fe._fe_model import check_fe_model

__all__ = ["Measured", "MeasuredModes", "error_level", "identify_measured", "measured_modes",
           "place_test"]

#: the modes are identified on at most this many lines (every k-th line of a longer test;
#: decimating further would blur lightly damped peaks narrower than a few lines)
ID_MAX_LINES = 2000
#: median of a chi-square variable with one degree of freedom (robust variance estimate)
CHI2_MEDIAN = 0.454936


@dataclass(frozen=True, eq=False)
class Measured:
    """A test placed on an FE model: band-limited lines as displacement/force.

    Parameters
    ----------
    frf : FRF
        The measured FRF restricted to the band (its own quantity).
    omega : ndarray, shape (nf,)
        Lines in rad/s.
    H : ndarray, shape (nf, ns, na)
        Displacement/force responses.
    logH : ndarray, shape (nf, ns, na)
        ``log |H|``.
    sensors, actuators : ndarray of int
        DOF indices of the sensors and actuators on the FE model.
    """

    frf: object
    omega: np.ndarray
    H: np.ndarray
    logH: np.ndarray
    sensors: np.ndarray
    actuators: np.ndarray

    @property
    def freq(self) -> np.ndarray:
        """Lines in Hz."""
        return self.frf.freq


def place_test(fe, frf, band=None, name: str = "frf") -> Measured:
    """Place a measured FRF on an FE model by its labels (DOF labels of ``fe``).

    Parameters
    ----------
    fe : FEModel
        The model.
    frf : FRF
        Measured FRFs whose sensor and actuator labels are DOF labels of ``fe``.
    band : (float, float), optional
        Band in Hz (default: all lines).
    name : str
        Name of ``frf`` in error messages.

    Returns
    -------
    Measured
    """
    from sdctrl.data._frf import FRF

    check_fe_model(fe, "fe")
    if not isinstance(frf, FRF):
        raise TypeError(f"{name} must be an sdctrl.FRF, got {type(frf).__name__}")
    known = set(fe.dofs)
    for side, labels in (("sensor", frf.sensors), ("actuator", frf.actuators)):
        bad = [lab for lab in labels if lab not in known]
        if bad:
            raise ValueError(f"{name}: {side} labels must be DOF labels of fe (like "
                             f"{fe.dofs[0]!r}); unknown: {bad[:5]}")
    data = frf
    if band is not None:
        lo, hi = check_band(band, "band")
        data = frf.band(lo, hi)
        if data.freq.size < 2:
            raise ValueError(f"band ({lo:g}, {hi:g}) Hz holds fewer than 2 lines of {name}")
    w = 2 * np.pi * data.freq
    H = data.H / ((1j * w) ** QUANTITY_POWER[data.quantity])[:, None, None]
    a = np.abs(H)
    if not np.all(np.isfinite(a) & (a > 0)):
        raise ValueError(f"{name}: the displacement |H / (j w)^k| must be finite and positive "
                         "on every line of the band (the logLS cost takes its logarithm); "
                         "frequencies or values too large or too small for double precision?")
    H.setflags(write=False)
    logH = np.log(a)
    logH.setflags(write=False)
    return Measured(data, w, H, logH, fe.dof_index(list(frf.sensors)),
                    fe.dof_index(list(frf.actuators)))


@dataclass(frozen=True, eq=False)
class MeasuredModes:
    """Normal modes of the measured data.

    Parameters
    ----------
    frequency : ndarray, shape (n,)
        Natural frequencies (Hz).
    damping : ndarray, shape (n,)
        Damping ratios.
    shapes : ndarray, shape (ns, n)
        Modal observabilities at the test sensors (real for normal modes, complex for
        complex modes).
    Gamma : ndarray, shape (n, n) or None
        Full modal damping matrix (rad/s) when normal modes were obtained.
    source : str
        Where they come from.
    """

    frequency: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    Gamma: np.ndarray | None
    source: str

    @property
    def n(self) -> int:
        """Number of modes."""
        return self.frequency.size


def _rows(model, sensors, name):
    """Row index of each test sensor in a model's sensor labels."""
    labels = list(model.sensors)
    if labels == list(sensors):
        return np.arange(len(labels))
    missing = [s for s in sensors if s not in labels]
    if missing:
        raise ValueError(f"{name}: its sensors must include the test's; missing {missing[:5]}")
    return np.array([labels.index(s) for s in sensors])


def _from_normal(nm, sensors, source):
    rows = _rows(nm, sensors, "identified")
    w = 2 * np.pi * nm.frequency
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(w > 0, np.diag(nm.Gamma) / (2 * w), 0.0)
    return MeasuredModes(nm.frequency.copy(), z, np.asarray(nm.cphi)[rows],
                     np.array(nm.Gamma, float), source)


def _from_complex(cm, sensors, source):
    rows = _rows(cm, sensors, "identified")
    keep = np.asarray(cm.in_band, bool)
    R = np.asarray(cm.residues)[keep][:, rows]                   # (n, ns, na)
    shapes = np.linalg.svd(R)[0][:, :, 0].T if R.shape[0] else np.zeros((len(rows), 0))
    return MeasuredModes(np.asarray(cm.frequency)[keep], np.asarray(cm.damping)[keep], shapes,
                     None, source)


def identify_measured(measured: Measured):
    """Complex modes of the test: :func:`sdctrl.identify` on the band (every k-th line when it
    holds more than :data:`ID_MAX_LINES`: frequencies, damping and shapes need no more).

    Parameters
    ----------
    measured : Measured
        The test.

    Returns
    -------
    ComplexModeModel
    """
    from sdctrl.data._frf import FRF
    from sdctrl.identification import identify

    frf = measured.frf
    step = -(-frf.freq.size // ID_MAX_LINES)
    if step > 1:
        frf = FRF(frf.freq[::step], frf.H[::step], quantity=frf.quantity,
                  sensors=frf.sensors, actuators=frf.actuators, collocated=frf.collocated)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return identify(frf, progress=False)
    except (ValueError, np.linalg.LinAlgError) as exc:   # numerical trouble named, not hidden
        raise ValueError(f"frf: the modes of the test could not be identified "
                         f"({type(exc).__name__}: {exc})") from None


def measured_modes(measured: Measured, identified=None) -> MeasuredModes:
    """Normal (or complex) modes of the test for pairing and damping.

    Parameters
    ----------
    measured : Measured
        The test placed on the FE model.
    identified : NormalModeModel or ComplexModeModel, optional
        An identified model of the test (sensors labelled like the test's); default:
        :func:`identify_measured`, then :func:`sdctrl.normal_modes` of its in-band modes when
        the test has collocated pairs.

    Returns
    -------
    MeasuredModes
    """
    from sdctrl.identification import ComplexModeModel, normal_modes
    from sdctrl.modal._normal_model import NormalModeModel

    sensors = measured.frf.sensors
    if isinstance(identified, NormalModeModel):
        return _from_normal(identified, sensors, "given normal modes")
    if identified is not None and not isinstance(identified, ComplexModeModel):
        raise TypeError("identified must be a NormalModeModel or a ComplexModeModel, got "
                        f"{type(identified).__name__}")
    cm = identify_measured(measured) if identified is None else identified
    if measured.frf.collocated and np.any(cm.in_band):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                nm = normal_modes(cm, measured.frf.collocated, modes=cm.in_band)
            return _from_normal(nm, sensors, "identified normal modes")
        except ValueError:
            pass                                    # fall back on the complex modes
    return _from_complex(cm, sensors, "identified complex modes")


def error_level(measured: Measured, identified=None, n_averages: int = 1) -> tuple[float, str]:
    """Expected logLS cost of the measurement against the true response.

    Parameters
    ----------
    measured : Measured
        The test.
    identified : ComplexModeModel or NormalModeModel, optional
        Model whose misfit measures the error without a coherence measuring it (default:
        :func:`identify_measured`).
    n_averages : int
        Averages of the FRF estimate (coherence-based level).

    Returns
    -------
    level : float
        Mean squared log-magnitude error (robust estimate from an identified fit).
    source : str
        ``"coherence"`` or ``"identified fit"``.
    """
    frf = measured.frf
    coh = measured_coherence(frf)
    if coh is not None:
        coh = np.broadcast_to(coh if coh.ndim == 3 else coh[:, :, None], frf.H.shape)
        return float(np.mean((1.0 - coh) / (2.0 * n_averages))), "coherence"
    model = identify_measured(measured) if identified is None else identified
    pred = model.frf(frf.freq, frf.quantity)
    r2 = (np.log(np.abs(pred.H) + 1e-300) - np.log(np.abs(frf.H) + 1e-300)) ** 2
    return float(np.median(r2) / CHI2_MEDIAN), "identified fit"
