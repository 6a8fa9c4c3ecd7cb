"""What :func:`sdctrl.identify` reports besides the model (thesis 3.1-3.2): typed records.

:class:`Stabilisation` holds the LSCF poles of every model order (the stabilisation diagram,
``ComplexModeModel.stabilisation``); :class:`SearchDiagnostics` how the pole search went
(``ComplexModeModel.search``: evaluations, convergence, data compression, interruption).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.records import freeze_arrays

__all__ = ["SearchDiagnostics", "Stabilisation"]


@dataclass(frozen=True, eq=False)
class Stabilisation(FrozenState):
    """LSCF poles of every model order, the input of :func:`sdctrl.plot.stabilisation`.

    Attributes
    ----------
    orders : ndarray of int, shape (k,)
        Model orders computed.
    poles : tuple of ndarray
        For each order, every root of its denominator (complex, rad/s).
    """

    orders: np.ndarray | None = None
    poles: tuple = ()

    def __post_init__(self):
        freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class SearchDiagnostics(FrozenState):
    """How the pole search of :func:`sdctrl.identify` went (3.18)-(3.19).

    Every field may be None in files written before it existed.

    Attributes
    ----------
    optimizer : str
        ``"varpro"``, ``"gradient"`` or ``"none"``.
    model : str
        Residue parametrisation (``"complex"``, ...).
    asymptotic : bool
        Whether ``E`` and ``F`` were fitted.
    compress_rank : int
        Rank of the compressed data the search ran on.
    compression_residual : float or None
        Relative part of the data the compression leaves out (None: not compressed).
    lines, channels : int
        Frequency lines of the band and data channels.
    nfev : int
        Cost evaluations of the whole identification.
    converged : bool
        Whether the last pole search converged.
    status : int or None
        Optimiser status of the last search.
    message : str or None
        Optimiser message of the last search.
    interrupted : bool
        True when the automatic selection was interrupted (Ctrl-C) and the last complete
        fit returned.
    rcond : float
        Reciprocal condition number of the final pole basis (3.16).
    logls : float or None
        Mean logLS (3.12) of the model against the lines it was fitted to, as measured
        (through the exponential window of windowed data): the closeness
        :func:`sdctrl.normal_modes` asks of the normal modes to this model.
    weighting : str or None
        How the lines were weighted in the fit (:mod:`~sdctrl.identification._line_weights`):
        ``"level"`` (each line by its level across the channels, the logLS cost 3.12
        linearised) or ``"none"`` (None: a model from before the option).
    weighting_logls : (float, float) or None
        With ``weighting="auto"`` on data whose lines may be weighted: the mean logLS
        against the data of the unweighted and of the level-weighted fit; the lower was
        kept (None: one fit only).
    weighting_variance : (float, float) or None
        With ``"auto"`` on data with a coherence below one: the mean squared misfit over the
        point variance (3.59) of both fits, the measure that chose between them (None: the
        logLS chose, or one fit only).
    residual_decay : float or None
        For data that record no exponential window: the decay over the record of the
        residual of the selection's start (``2 T/tau`` of an equivalent window, ``T = 1/df``)
        when it showed noise correlated between lines and chose the rules of windowed data
        (:mod:`~sdctrl.identification._residual_decay`); None otherwise.
    """

    optimizer: str | None = None
    model: str | None = None
    asymptotic: bool | None = None
    compress_rank: int | None = None
    compression_residual: float | None = None
    lines: int | None = None
    channels: int | None = None
    nfev: int | None = None
    converged: bool | None = None
    status: int | None = None
    message: str | None = None
    interrupted: bool = False
    rcond: float | None = None
    logls: float | None = None
    weighting: str | None = None
    weighting_logls: tuple | None = None
    weighting_variance: tuple | None = None
    residual_decay: float | None = None

    def __post_init__(self):
        freeze_arrays(self)
