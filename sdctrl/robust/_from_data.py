"""Uncertain models whose bounds come from the data (thesis 3.4 and 5.2.3).

Two sources of bounds on the parameters of a normal-mode model (5.5):

* the statistics of one identification, ``NormalModeModel.std`` (propagated from the noise
  of the test, 3.56-3.59): a Gaussian two-sided quantile ``z`` of ``level`` times each
  standard deviation;
* several tests of one structure (5.2.3): the mean model (modes aligned by MAC,
  :func:`~sdctrl.robust._multitest.multi_test_statistics`) and the sample spread ``s`` of each
  parameter, bounded by the prediction interval ``t_{N-1} s sqrt(1 + 1/N)`` (Student quantile
  of ``level``) that covers a further test of the structure.

With several tests that also carry statistics, each bound is the larger of the two (the
statistical bound with the root-mean-square standard deviation of the tests).  The source is
recorded in :attr:`UncertainModel.source`.  The residual terms ``E`` and ``F`` of the nominal
model stay as they are, certain (:mod:`._fixed_parts`): the uncertain model's nominal plant is
the model's own.

The residual dynamics of one identified model (complex modes kept as they are: poles fitted
outside the band, modes that could not be made proper) are as uncertain as the modes: their
poles' and residues' standard deviations (3.56), (3.58), carried by
:class:`~sdctrl.modal.ResidualDynamics`, bound them the same way (``z`` std); those the data
do not determine (NaN) stay certain, and the source says how many.  Left certain, they move
from test to test outside the envelope: the FRF envelope of a plate's 3 x 1 subtest held the
truth at 57% of its lines at 95% (27% at 50%), now at 98% (68%: the hull of a box of
independent intervals is conservative; tests/test_statistics_envelope.py).  With several tests the
residual dynamics stay certain (their poles need not pair from test to test).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sdctrl.robust._multitest import multi_test_statistics
from sdctrl.robust._uncertainty import UncertainModel, uncertain

__all__ = ["uncertain_from_data"]

_KEYS = {"Gamma": "dGamma", "Omega": "dOmega", "phib": "db", "cphi": "dc"}
#: largest bound on a residual pole's decay rate ``-Re l``, as a fraction of it: a passive
#: structure's poles are stable, and a bound reaching the axis would make every loop's margin
#: that of an open-loop instability the data do not show
PASSIVE_DECAY = 0.5


def uncertain_from_data(models, level: float = 0.95) -> UncertainModel:
    """Structured uncertain model (5.5) with bounds from identification statistics or tests.

    Parameters
    ----------
    models : NormalModeModel or sequence of NormalModeModel
        One identified model with statistics (``std``, from :func:`~sdctrl.normal_modes` of
        :func:`~sdctrl.identify`), or several identified models of the same structure
        (same numbers of modes, sensors and actuators; several tests, 5.2.3).
    level : float
        Probability, in (0, 1), with which each bound covers its parameter.

    Returns
    -------
    UncertainModel
        Nominal model (the model, or the mean of the tests) and bounds ``dGamma``,
        ``dOmega``, ``db``, ``dc``; ``source`` says where the bounds come from.

    Raises
    ------
    TypeError
        ``models`` is not a normal-mode model or a sequence of them.
    ValueError
        ``level`` outside (0, 1); a single model without statistics (or with undetermined
        ones); models of different sizes.

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> nm = sd.NormalModeModel(np.diag([100.0, 400.0]), np.diag([0.2, 0.4]), np.eye(2),
    ...                         np.eye(2), std={"Omega": np.diag([1.0, 2.0]),
    ...                         "Gamma": np.diag([0.01, 0.02]), "cphi": np.zeros((2, 2)),
    ...                         "phib": np.zeros((2, 2))})
    >>> um = sd.uncertain_from_data(nm, level=0.95)
    >>> round(float(um.dOmega[0, 0]), 3)
    1.96
    """
    from scipy.stats import norm, t

    if isinstance(level, bool) or not isinstance(level, int | float) or not 0 < level < 1:
        raise ValueError(f"level must be a probability in (0, 1), got {level!r}")
    many = isinstance(models, list | tuple)
    models = list(models) if many else [models]
    for i, m in enumerate(models):
        if not all(hasattr(m, k) for k in ("Omega", "Gamma", "cphi", "phib", "std")):
            raise TypeError(f"models[{i}] must be a NormalModeModel, got {type(m).__name__}")
    if not models:
        raise ValueError("models must hold at least one NormalModeModel")
    z = float(norm.ppf(0.5 + level / 2))
    if len(models) == 1:
        m = models[0]
        if m.std is None:
            raise ValueError("models: a single model must carry statistics (std), as "
                             "sd.normal_modes(sd.identify(frf)) gives; give several tests "
                             "of the structure otherwise")
        bounds = {k: z * np.asarray(m.std[k]) for k in _KEYS}
        source = f"identification statistics ({level:.0%}: {z:.3g} std)"
        nominal = m
        residual, note = _statistical_residual_bounds(m, z)
        source += note
    else:
        residual = {}
        res = multi_test_statistics(models)
        N = len(models)
        tq = float(t.ppf(0.5 + level / 2, N - 1)) * np.sqrt(1 + 1 / N)
        bounds = {k: tq * np.asarray(res.std[k]) for k in _KEYS}
        source = f"spread of {N} tests ({level:.0%}: {tq:.3g} sample std)"
        stds = [a.std for a in res.aligned if a.std is not None]
        if stds:
            for k in _KEYS:
                rms = np.sqrt(np.mean([np.asarray(s[k]) ** 2 for s in stds], axis=0))
                bounds[k] = np.fmax(bounds[k], z * rms)
            source = (f"larger of the spread of {N} tests ({tq:.3g} sample std) and their "
                      f"identification statistics ({z:.3g} std), {level:.0%}")
        nominal = res.mean
    bad = [k for k in _KEYS if not np.all(np.isfinite(bounds[k]))]
    if bad:
        raise ValueError(f"models: the statistics of {bad} are undetermined (NaN): the data "
                         "do not determine these parameters; give several tests")
    um = uncertain(nominal, **{_KEYS[k]: bounds[k] for k in _KEYS}, **residual)
    return dataclasses.replace(um, source=source)


def _statistical_residual_bounds(model, z: float) -> tuple[dict, str]:
    """``z`` std bounds of the model's residual dynamics (NaN: certain) and a note."""
    res = getattr(model, "residual", None)
    if res is None or res.pole_std is None or res.residue_std is None:
        return {}, ""
    dp, dr = (np.nan_to_num(z * a.real, nan=0.0) + 1j * np.nan_to_num(z * a.imag, nan=0.0)
              for a in (res.pole_std, res.placed(model.sensors, model.actuators, std=True)))
    # passivity (as Gamma's bounds in 5.2.2): a decay rate moves by at most half its value
    dp = np.minimum(dp.real, PASSIVE_DECAY * np.abs(res.poles.real)) + 1j * dp.imag
    known = int(np.sum(np.isfinite(res.pole_std.real) & np.isfinite(res.pole_std.imag)))
    note = f"; residual dynamics: {known} of {res.m} poles uncertain"
    if known < res.m:
        note += " (the others undetermined by the data, certain)"
    return {"dpoles": dp, "dresidues": dr}, note
