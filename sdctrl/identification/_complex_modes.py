"""Complex-mode models (thesis 3.1, parametrisation 3.7) and their MIMO forms (3.2).

``H_d(s) = sum_j [R_j/(s - lambda_j) + R_j^*/(s - lambda_j^*)] + E + F/s^2``
describes the displacement/force response; ``E`` is the residual flexibility of
modes above the band, ``F/s^2`` the residual mass of modes below it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from sdctrl._lib.display import MAX_ROWS, hz_range, markdown_table, one_line
from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.validate import (
    QUANTITY_POWER,
    as_array,
    check_band,
    check_collocated,
    check_finite_result,
    check_freq,
    check_info,
    check_labels,
    check_quantity,
    check_scalar,
    readonly,
)
from sdctrl.identification._fit_records import SearchDiagnostics, Stabilisation
from sdctrl.identification._pole_statistics import FitStatistics, pole_std
from sdctrl.identification._realisation import to_statespace

__all__ = ["ComplexModeModel", "frf_array", "scale_residues", "to_statespace"]


@dataclass(frozen=True, eq=False)
class ComplexModeModel(FrozenState):
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
        Diagnostics nobody relies on (the selection log).
    stabilisation : Stabilisation, optional
        LSCF poles of every model order (:class:`~sdctrl.identification._fit_records.Stabilisation`)
        when :func:`sdctrl.identify` chose the poles itself.
    warnings : tuple of str
        What :func:`sdctrl.identify` warned about (also issued as warnings).
    search : SearchDiagnostics, optional
        How the pole search went (:class:`~sdctrl.identification._fit_records.SearchDiagnostics`:
        ``nfev``, ``converged``, ``compress_rank``, ``interrupted``...).
        Diagnostics of the fit (iterations, warnings, optimiser).
    exponential_tau : float, optional
        Time constant (s) of the data's exponential window ``exp(-t/tau)`` (impact tests): it
        added ``1/tau`` rad/s to every decay rate, :func:`~sdctrl.identify` removed it
        (``poles.real += 1/tau``); None when no correction was applied.
    statistics : FitStatistics, optional
        Covariance of the poles and residues under the test's noise (3.56)-(3.59), set by
        :func:`~sdctrl.identify`; None for a model without statistics.
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
    stabilisation: Stabilisation | None = field(default=None, repr=False)
    warnings: tuple[str, ...] = field(default=(), repr=False)
    search: SearchDiagnostics | None = field(default=None, repr=False)
    exponential_tau: float | None = None
    statistics: FitStatistics | None = field(default=None, repr=False)

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
        E, F = (np.zeros((ns, na)) if X is None else as_array(X, f"{k} (ns x na of residues)",
                shape=(ns, na)) for k, X in (("E", self.E), ("F", self.F)))
        ib = _mask(self.in_band, n)
        sensors = check_labels(self.sensors, ns, "sensors", "s")
        actuators = check_labels(self.actuators, na, "actuators", "a")
        sets = object.__setattr__
        sets(self, "poles", readonly(lam))
        sets(self, "residues", readonly(R))
        sets(self, "E", readonly(E))
        sets(self, "F", readonly(F))
        sets(self, "in_band", readonly(ib))
        sets(self, "cost", _cost(self.cost))
        sets(self, "band", None if self.band is None else check_band(self.band, "band"))
        sets(self, "sensors", sensors)
        sets(self, "actuators", actuators)
        sets(self, "collocated", check_collocated(self.collocated, ns, na, "collocated",
                                                  sensors, actuators))
        sets(self, "info", check_info(self.info))
        _check_records(self)
        if self.exponential_tau is not None:
            sets(self, "exponential_tau", check_scalar(self.exponential_tau, "exponential_tau",
                                                       positive=True))
        if self.statistics is not None and (not isinstance(self.statistics, FitStatistics)
                                            or self.statistics.n != n):
            raise ValueError(f"statistics must be a FitStatistics of {n} poles or None, got "
                             f"{self.statistics!r:.60}")

    # --- display --------------------------------------------------------------------
    def __repr__(self) -> str:
        nin = int(np.count_nonzero(self.in_band))
        return one_line("ComplexModeModel", [
            f"n={self.n}", f"ns={self.ns}", f"na={self.na}", hz_range(self.frequency),
            f"{nin} in band" if nin < self.n else "",
            "" if self.band is None else f"band={hz_range(self.band)}",
            "" if np.isnan(self.cost) else f"cost={self.cost:.3g}"])

    def _repr_markdown_(self) -> str:
        rows = [(j + 1, f"{self.frequency[j]:.4g}", f"{100 * self.damping[j]:.3g}",
                 "yes" if self.in_band[j] else "no") for j in range(self.n)]
        return (f"`{self!r}`\n\n" + markdown_table(
            ["mode", "frequency (Hz)", "damping (%)", "in band"], rows, MAX_ROWS))

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

    @property
    def frequency_std(self) -> np.ndarray:
        """One standard deviation of each pole's frequency (Hz) under the test's noise
        (3.56)-(3.59); NaN where the data do not determine it (or without statistics)."""
        return pole_std(self.statistics, self.poles)[0]

    @property
    def damping_std(self) -> np.ndarray:
        """One standard deviation of each pole's damping ratio (as :attr:`frequency_std`)."""
        return pole_std(self.statistics, self.poles)[1]

    def replace(self, **changes) -> ComplexModeModel:
        """Copy with some fields changed (validated again; ``statistics`` dropped with new
        poles or channels)."""
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        if "poles" in changes or np.shape(changes.get("residues", self.residues)) != \
                self.residues.shape:
            kw["statistics"] = None                # they described other poles or channels
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
        from sdctrl.data._frf import FRF

        f = check_freq(freq, "freq")
        q = check_quantity(quantity, "quantity")
        s = 2j * np.pi * f
        with np.errstate(all="ignore"):
            H = frf_array(self.poles, self.residues, self.E, self.F, s)
            H = H * (s ** QUANTITY_POWER[q])[:, None, None]
        check_finite_result(H, "the FRF", "freq or the model's poles, residues, E, F")
        return FRF(f, H, quantity=q, sensors=self.sensors, actuators=self.actuators,
                   collocated=self.collocated)


    # --- minimality and scaling (3.2.2-3.2.3) -------------------------------------------
    def singular_value_ratios(self) -> np.ndarray:
        """Ratios ``sigma_k / sigma_1`` of the singular values of each residue matrix (3.22).

        ``sigma_2 / sigma_1`` is the relative norm ``||R_j - R~_j|| / ||R_j||`` of what the
        dyadic (minimal) residue (3.23) leaves out: small for a single mode, close to one
        for a double mode.

        Returns
        -------
        ndarray, shape (n, min(ns, na))
            One row per mode (zeros for a zero residue).
        """
        sv = np.linalg.svd(self.residues, compute_uv=False)      # (n, r)
        s1 = sv[:, :1]
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.where(s1 > 0, sv / np.where(s1 > 0, s1, 1.0), 0.0)
        return out

    def minimal(self, multiplicity=1) -> ComplexModeModel:
        """Model with dyadic residues: the first dyads of each residue's SVD (3.22)-(3.23).

        Parameters
        ----------
        multiplicity : int or array_like of int
            Number of dyads kept per mode (1: minimal model of distinct modes; 2 for a
            double mode, ...), a single value or one per mode.

        Returns
        -------
        ComplexModeModel
            Same poles, ``E``, ``F``; residues ``sum_k U_k sigma_k V_k^H`` truncated;
            ``info["singular_value_ratios"]`` holds the ratios of the original residues.
        """
        m = np.asarray(multiplicity) if not isinstance(multiplicity, str | bytes) else None
        if m is None or m.dtype.kind not in "iu" or m.ndim > 1 or np.any(m < 1):
            raise ValueError(f"multiplicity must be a positive integer (or one per mode), "
                             f"got {multiplicity!r:.60}")
        if m.ndim == 1 and m.size != self.n:
            raise ValueError(f"multiplicity must be one integer or {self.n} (one per mode), "
                             f"got {m.size}")
        mult = np.broadcast_to(m, (self.n,))
        U, sv, Vh = np.linalg.svd(self.residues, full_matrices=False)
        R = np.empty_like(self.residues)
        for j in range(self.n):
            kk = int(min(mult[j], sv.shape[1]))
            R[j] = (U[j, :, :kk] * sv[j, :kk]) @ Vh[j, :kk]
        info = dict(self.info)
        info["singular_value_ratios"] = self.singular_value_ratios()
        info["multiplicity"] = mult.copy()
        return self.replace(residues=R, info=info)

    def scaled(self, collocated=None, return_info: bool = False, spread_tol: float = 0.1):
        """Scaled complex modal observability and controllability (3.24)-(3.25).

        Each residue's first dyad ``U_1 sigma_1 V_1^H`` (3.23) gives the directions of
        ``c psi_j`` and ``psi_j^T b``; collocation (``c_l psi_j = psi_j^T b_l`` for a
        collocated pair ``l``) fixes the scale, ``alpha_j^2 = (R~_j)_ll`` (3.24).  With
        several collocated pairs the scale is the least-squares average: ``a^2``
        minimising ``sum_l |a^2 U_sl - sigma_1 conj(V_al)|^2`` over the pairs; the relative
        spread of the individual pair scalings is reported.

        Parameters
        ----------
        collocated : sequence of (int or str, int or str), optional
            Collocated (sensor, actuator) pairs; default ``self.collocated``.
        return_info : bool
            Also return a dict with ``"spread"`` (n,) (relative RMS deviation of the
            single-pair scalings ``alpha^2`` from the average) and ``"alpha2"`` (n, npairs).
        spread_tol : float
            A warning is issued for modes whose spread exceeds this value.

        Returns
        -------
        cpsi : ndarray, shape (ns, n)
            Scaled modal observabilities ``c psi_j`` (displacement).
        psib : ndarray, shape (n, na)
            Scaled modal controllabilities ``psi_j^T b``; ``cpsi[:, j] psib[j]`` is the
            dyadic residue ``R~_j`` and ``cpsi[s, j] = psib[j, a]`` for a collocated pair.
        info : dict
            Only with ``return_info=True``.

        Raises
        ------
        ValueError
            No collocated pair, or a mode that no pair sees (its scaling would be NaN).
        """
        import warnings

        pairs = self.collocated if collocated is None else check_collocated(
            collocated, self.ns, self.na, "collocated", self.sensors, self.actuators)
        if not pairs:
            raise ValueError("collocated must name at least one (sensor, actuator) pair "
                             "(the model has none)")
        spread_tol = check_scalar(spread_tol, "spread_tol", nonneg=True, allow_inf=True)
        with np.errstate(all="ignore"):
            cpsi, psib, k = scale_residues(self.residues, pairs)
        single, spread = k["single"], k["spread"]
        unseen = ~np.isfinite(psib).all(axis=1) | ~np.isfinite(cpsi).all(axis=0)
        if np.any(unseen):
            raise ValueError("collocated: modes " + ", ".join(
                str(j) for j in np.flatnonzero(unseen)) + " are not seen by any collocated "
                "pair (zero residue there), so their scaling is undefined; give a pair that "
                "sees them or drop them from residues")
        if len(pairs) > 1 and np.any(spread > spread_tol):
            bad = np.flatnonzero(spread > spread_tol)
            warnings.warn("scaled: collocated pairs disagree on the scaling of modes "
                          + ", ".join(f"{j} ({spread[j]:.0%})" for j in bad),
                          RuntimeWarning, stacklevel=2)
        if return_info:
            return cpsi, psib, {"spread": spread, "alpha2": single, "pairs": pairs}
        return cpsi, psib

    def residue_std(self, frf=None, n_averages: int | None = None, direct_only: bool = False):
        """Standard deviation of the residues, both parts of (3.58) (direct and through the
        poles), from the coherence (3.59) or the fit residual.

        Parameters
        ----------
        frf : FRF, optional
            The measured FRF the model was fitted to; default the statistics stored by
            :func:`~sdctrl.identify`.
        n_averages : int, optional
            Divisor of the point variance (3.59); default ``frf.averages - 1`` (else 1).
        direct_only : bool
            Only the direct part of (3.58) (poles held fixed).

        Returns
        -------
        ndarray, shape (n, ns, na)
            Standard deviation of each complex residue (``sqrt(var Re + var Im)``); NaN
            without statistics.
        """
        from sdctrl.identification._variance import residue_std

        return residue_std(self, frf, n_averages, direct_only)

    def to_statespace(self, quantity: str = "displacement", omega_c: float | None = None):
        """Real state-space model in the 2x2-block modal form (3.26)-(3.33).

        Parameters
        ----------
        quantity : {"displacement", "velocity", "acceleration"}
            Output quantity.
        omega_c : float, optional
            Cut-off (rad/s) of the critically damped correction filter realising the
            improper terms for velocity/acceleration outputs; default ten times the
            highest modal frequency.

        Returns
        -------
        control.StateSpace
            Real ``A, B, C, D``; outputs named after the sensors, inputs after the actuators
            plus ``_u`` (``.`` replaced by ``_``); exact for displacement (``E`` as
            feedthrough, ``F/s^2`` by a double integrator per actuator).

        Warnings
        --------
        ``control.feedback`` drops signal names (``y[0]``...): use :func:`sdctrl.feedback`.

        Notes
        -----
        Each residue is split into dyads ``u_k (sigma_k v_k^H)`` (all non-negligible
        ones, so a non-minimal residue is reproduced exactly) and each dyad becomes a
        2-state block ``[[0, 1], [-w^2, -2 z w]]`` with ``C1, C2, B1, B2`` of (3.33)
        (``a = 1`` in 3.32).  Velocity and acceleration multiply by ``s``, ``s^2``: the
        strictly proper part stays exact, while ``E s^k`` and, for acceleration, the
        ``s sum_j (R_j + R_j^*)`` term (zero for proper modes, 3.39) are realised through
        ``w_c^2 / (s + w_c)^2`` (2.20), accurate to about ``2 w / w_c`` in the band.
        """
        return to_statespace(self, quantity, omega_c)


def _check_records(cm) -> None:
    """Types of the fit's records: ``stabilisation``, ``warnings`` (strings), ``search``."""
    for name, kind in (("stabilisation", Stabilisation), ("search", SearchDiagnostics)):
        if getattr(cm, name) is not None and not isinstance(getattr(cm, name), kind):
            raise TypeError(f"{name} must be a {kind.__name__} or None, got "
                            f"{type(getattr(cm, name)).__name__}")
    w = cm.warnings
    if isinstance(w, str) or not all(isinstance(m, str) for m in w):
        raise TypeError("warnings must be a sequence of str")
    object.__setattr__(cm, "warnings", tuple(w))


def _mask(in_band, n: int) -> np.ndarray:
    """``in_band`` as a boolean mask of ``n`` entries (True, False, 1 or 0 only)."""
    if in_band is None:
        return np.ones(n, bool)
    m = np.array(in_band, copy=True) if not isinstance(in_band, str | bytes) else np.array([])
    if m.ndim != 1 or m.size != n or m.dtype.kind not in "biuf" or not np.all(
            (m == 0) | (m == 1)):
        raise ValueError(f"in_band must be a boolean mask of {n} entries (one per pole), got "
                         f"{in_band!r:.60}")
    return m.astype(bool)


def _cost(cost) -> float:
    """A real cost (NaN: unknown)."""
    if isinstance(cost, float | np.floating) and np.isnan(cost):
        return float("nan")
    return check_scalar(cost, "cost", allow_inf=True)     # inf: no fit (e.g. overflow)


def scale_residues(residues, pairs):
    """Scaling of the dyadic residues by collocated pairs, eq. (3.24)-(3.25) (kernel).

    The first dyad ``R_j ~ u_j w_j^T`` (``w_j = sigma_1 conj(V_1)``, 3.23) is scaled by
    ``kappa_j`` so that ``cpsi_j = kappa_j u_j`` and ``psib_j = w_j / kappa_j`` agree at the
    collocated pairs; ``kappa_j^2 = z_j = sum_l conj(u_sl) w_al / sum_l |u_sl|^2`` is the
    least-squares compromise over the pairs.  Modes with ``z_j = 0`` get NaN scalings.
    Internal: inputs are trusted; callers decide how to report unscalable modes.

    Parameters
    ----------
    residues : array_like, shape (n, ns, na), complex
        Residues of the complex-mode model.
    pairs : sequence of (int, int)
        Collocated (sensor, actuator) index pairs.

    Returns
    -------
    cpsi : ndarray, shape (ns, n)
    psib : ndarray, shape (n, na)
    details : dict
        ``z`` (n,) the scalings ``kappa^2``; ``single`` (n, npairs) the single-pair
        scalings; ``spread`` (n,) their relative RMS deviation from ``z``; ``observed`` (n,)
        ``sum_l |u_sl|^2``; ``sigma1`` (n,) the first singular values.
    """
    U, sv, Vh = np.linalg.svd(np.asarray(residues), full_matrices=False)
    u = U[:, :, 0]                        # (n, ns)
    v = Vh[:, 0, :] * sv[:, :1]           # (n, na) sigma_1 V_1^H
    si = np.array([p[0] for p in pairs])
    ai = np.array([p[1] for p in pairs])
    us, va = u[:, si], v[:, ai]           # (n, npairs)
    observed = np.sum(np.abs(us) ** 2, axis=1)
    z = np.sum(us.conj() * va, axis=1) / np.maximum(observed, 1e-300)
    with np.errstate(invalid="ignore", divide="ignore"):
        single = np.where(np.abs(us) > 0, va / np.where(np.abs(us) > 0, us, 1), np.nan)
    dev2 = np.abs(single - z[:, None]) ** 2
    count = np.sum(~np.isnan(dev2), axis=1)              # nanmean without empty-slice warnings
    msd = np.where(count > 0, np.nansum(dev2, axis=1) / np.maximum(count, 1), np.nan)
    spread = np.sqrt(msd) / np.maximum(np.abs(z), 1e-300)
    a = np.sqrt(z.astype(complex))
    with np.errstate(invalid="ignore", divide="ignore"):
        cpsi = (u * a[:, None]).T
        psib = v / np.where(z == 0, np.nan, a)[:, None]
    return cpsi, psib, {"z": z, "single": single, "spread": spread, "observed": observed,
                        "sigma1": sv[:, 0]}


def frf_array(poles, residues, E, F, s) -> np.ndarray:
    """Displacement FRF (ns x na per line) of (3.7) at Laplace points ``s`` (rad/s).

    Parameters
    ----------
    poles : ndarray, shape (n,)
        Poles (rad/s), upper half-plane.
    residues : ndarray, shape (n, ns, na), complex
        Residues.
    E : ndarray, shape (ns, na)
        Residual flexibility.
    F : ndarray, shape (ns, na) or None
        Residual mass term ``F/s^2``.
    s : ndarray, shape (nf,)
        Laplace points ``j w`` (rad/s).

    Returns
    -------
    ndarray, shape (nf, ns, na), complex
    """
    g = 1.0 / (s[:, None] - poles[None, :])             # (nf, n)
    gc = 1.0 / (s[:, None] - poles.conj()[None, :])
    H = np.einsum("wn,nij->wij", g, residues) + np.einsum("wn,nij->wij", gc, residues.conj())
    H = H + E[None]
    if F is not None and np.any(F):
        H = H + F[None] / (s[:, None, None] ** 2)
    return H
