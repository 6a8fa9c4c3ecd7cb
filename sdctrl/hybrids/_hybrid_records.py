"""How a hybrid model was built (thesis 5.1.1): typed records and the pairing table.

:func:`sdctrl.hybrid` pairs the measured modes with FE modes (MAC), expands the measured
shapes onto the FE DOFs (4.7), absorbs the out-of-band poles that pair with no FE mode and
chooses its residual terms against the identified model.  What it found is read from
``HybridModel.construction`` (:class:`HybridConstruction`, with :class:`ModePairing` and
:class:`ResidualChoice`); :func:`pairing_report` tabulates the pairing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.records import freeze_arrays

__all__ = ["KINDS", "HybridConstruction", "MassScale", "ModePairing", "ResidualChoice",
           "pairing_report"]

#: origins of the modes of a hybrid model (``HybridModel.kind``)
KINDS = ("measured", "fe", "residual", "static")


@dataclass(frozen=True, eq=False)
class ModePairing(FrozenState):
    """FE/test mode pairing of the kept measured modes, one row each (5.1.1).

    Attributes
    ----------
    test_mode : ndarray of int
        Index of the measured mode in the identified model.
    fe_mode : ndarray of int
        Index of its paired FE mode.
    mac : ndarray
        MAC of the pair, at the test sensors.
    test_hz, fe_hz : ndarray
        Measured and FE frequencies (Hz).
    poor : ndarray of int
        Rows whose MAC is below ``mac_min`` (reported with a warning).
    """

    test_mode: np.ndarray | None = None
    fe_mode: np.ndarray | None = None
    mac: np.ndarray | None = None
    test_hz: np.ndarray | None = None
    fe_hz: np.ndarray | None = None
    poor: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class ResidualChoice(FrozenState):
    """The residual terms a hybrid kept (:func:`~sdctrl.hybrids._hybrid_basis.select_residual`).

    Attributes
    ----------
    variant : str
        The kept variant (``"kappa, mass+E"``, ``"kappa, E"``, ``"fe"``...; with
        ``residual="tested"``: ``"tested I/O kept; appended modes as in <variant>"``, whose
        ``kappa`` alone matters there, the fits being replaced at the tested I/O).
    scores : dict of str to float
        logLS distance to the identified model at the tested I/O of every variant tried
        (empty when only one was possible).
    kappa : float
        Factor applied to the appended FE frequencies: the median measured/FE frequency
        ratio of the paired modes, or 1.
    representation : str
        The residual representation kept: ``"identified"``, ``"tested"`` or ``"fe"`` (the
        ``residual`` argument of :func:`sdctrl.hybrid`, or what ``"auto"`` chose).
    chosen_by : str or None
        With ``residual="auto"``: ``"leave-one-actuator-out"``, ``"leave-one-sensor-out"``
        (a test with one actuator) or ``"nominal"`` (one sensor and one actuator: nothing
        can be held out, the candidate closest to ``nm`` at the tested I/O is kept); None
        when ``residual`` was given (:func:`sdctrl.hybrids._auto.choose_residual`).
    held_out : ndarray of int or None
        Indices of the held-out actuators (sensors), one fold each.
    loo_scores : dict of str to float or None
        Per candidate representation, the mean logLS of its held-out predictions
        (:meth:`~sdctrl.hybrids.HybridModel.with_io` on the FE DOFs) against the
        identified model's own channels, over the band.
    nominal_scores : dict of str to float or None
        Per candidate, the logLS of the model built from the whole test against the
        identified model at the tested I/O (the tie-break).
    """

    variant: str | None = None
    scores: dict | None = None
    kappa: float | None = None
    representation: str | None = None
    chosen_by: str | None = None
    held_out: np.ndarray | None = None
    loo_scores: dict | None = None
    nominal_scores: dict | None = None

    def __post_init__(self):
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class OutOfBandTrial(FrozenState):
    """One out-of-band test pole tried as the frequency of an appended FE mode
    (:mod:`sdctrl.hybrids._out_of_band`).

    Attributes
    ----------
    pole_hz : float
        Frequency (Hz) of the identified pole (outside the band).
    fe_hz : float
        Frequency (Hz) of the FE mode it pairs with (before ``kappa``).
    nominal : tuple of float
        logLS of the ``"identified"`` hybrid against the identified model at the tested
        I/O, without and with the measured frequency.
    held_out : tuple of float or None
        Mean held-out logLS (leave-one-out, :mod:`sdctrl.hybrids._auto`) without and with
        it; None when the nominal test already refused it or nothing can be held out.
    kept : bool
        Whether the FE mode took the measured frequency.
    """

    pole_hz: float
    fe_hz: float
    nominal: tuple
    held_out: tuple | None
    kept: bool


@dataclass(frozen=True, eq=False)
class MassScale(FrozenState):
    """The scale of the measured modes' expanded shapes: the test's and the FE modal mass's,
    combined by their variances (:mod:`sdctrl.hybrids._mass_scale`).

    Attributes
    ----------
    test_mode : ndarray of int
        The measured modes (indices in the identified model).
    test_std : ndarray
        Relative standard deviation of the test's scale of each (from ``nm.std``).
    fe_log : ndarray
        ``-1/2 log(phi_Ex^T M phi_Ex)``: the log scale error the FE's mass reads.
    factor : ndarray
        Factor applied to each expanded shape (1: the test's scale kept).
    std : ndarray
        Standard deviation of ``log(factor)`` (the combined scale's).
    bias : float
        The log scale error common to every mode (an FE mass error).
    spread : float
        Standard deviation of the FE's own error, mode to mode (``tau``).
    """

    test_mode: np.ndarray
    test_std: np.ndarray
    fe_log: np.ndarray
    factor: np.ndarray
    std: np.ndarray
    bias: float
    spread: float


@dataclass(frozen=True, eq=False)
class HybridConstruction(FrozenState):
    """What :func:`sdctrl.hybrid` found while building the model (5.1.1, 4.7).

    Read as ``HybridModel.construction``; None for a hybrid made from an FE-derived model.

    Attributes
    ----------
    pairing : ModePairing
        FE/test pairing of the kept measured modes.
    mac : ndarray, shape (n_fe, n_test)
        MAC of every FE mode against every identified mode at the test sensors.
    absorbed : ndarray of int
        Identified modes (out of band, poorly paired) absorbed into the residual terms.
    expansion : ndarray
        Expansion coefficients ``A`` of the measured shapes on the expansion basis (4.7).
    mean_damping : float
        Damping ratio given to the appended FE modes (mean measured in-band one).
    fe_frequency_hz : ndarray
        Frequencies (Hz) of the FE modes considered.
    residual : ResidualChoice
        The residual variant kept and its scores.
    residual_flexibility : ndarray, shape (ns, na), or None
        The kept residual flexibility ``E`` at the test I/O (carried by the static
        correction modes, 2.22), None when none was kept.
    mass_correction : ndarray or None
        Eigenvalues of the low modes' inverse-mass correction (``"mass+E"`` variant).
    out_of_band : tuple of OutOfBandTrial
        With ``residual="auto"``: the out-of-band poles tried as appended FE modes'
        frequencies, kept or not, and the scores that decided.
    mass_scale : MassScale or None
        The measured modes' scale, the test's and the FE modal mass's combined (None when
        ``nm`` carries no statistics).
    """

    pairing: ModePairing | None = None
    mac: np.ndarray | None = None
    absorbed: np.ndarray | None = None
    expansion: np.ndarray | None = None
    mean_damping: float | None = None
    fe_frequency_hz: np.ndarray | None = None
    residual: ResidualChoice | None = None
    residual_flexibility: np.ndarray | None = None
    mass_correction: np.ndarray | None = None
    out_of_band: tuple = ()
    mass_scale: MassScale | None = None

    def __post_init__(self):
        freeze_arrays(self)


def pairing_report(model) -> str:
    """Markdown table of the FE/test mode pairing of a hybrid model.

    Parameters
    ----------
    model : HybridModel
        A model returned by :func:`sdctrl.hybrid`.

    Returns
    -------
    str
        One row per measured mode: test and FE frequencies (Hz), their ratio and the MAC,
        poor pairs flagged; with ``construction.mass_scale``, the factor applied to the
        expanded shape and its standard deviation (relative).
    """
    built = getattr(model, "construction", None)
    p = None if built is None else built.pairing
    if p is None or p.test_mode is None:
        raise ValueError("model has no pairing information (not built by hybrid)")
    poor = set(np.asarray(() if p.poor is None else p.poor).tolist())
    ms = built.mass_scale
    extra = ("", "") if ms is None else (" scale |", "---:|")
    rows = ["| test mode | test Hz | FE mode | FE Hz | FE/test | MAC |" + extra[0],
            "|---:|---:|---:|---:|---:|---:|" + extra[1]]
    for j in range(p.test_mode.size):
        flag = " (poor)" if j in poor else ""
        scale = "" if ms is None else f" {ms.factor[j]:.3f} +- {ms.std[j]:.3f} |"
        rows.append(f"| {j} | {p.test_hz[j]:.3f} | {p.fe_mode[j]} | {p.fe_hz[j]:.3f} "
                    f"| {p.fe_hz[j] / p.test_hz[j]:.4f} | {p.mac[j]:.3f}{flag} |{scale}")
    return "\n".join(rows)
