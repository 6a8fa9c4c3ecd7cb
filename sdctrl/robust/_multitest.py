"""Statistics of several identified models of one structure (thesis section 5.2.3).

Modes are aligned on a reference model (order and sign by MAC of the modal observabilities),
then the mean model and the sample standard deviation of each parameter give the bounds of a
structured uncertain model (:func:`sdctrl.robust._uncertainty.uncertain`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.display import one_line

__all__ = ["MultiTestResult", "multi_test_statistics"]


@dataclass(frozen=True, eq=False)
class MultiTestResult:
    """Mean model and spread from several tests (section 5.2.3).

    Parameters
    ----------
    mean : NormalModeModel
        Mean of the aligned models.
    std : dict
        Sample standard deviations of ``Gamma``, ``Omega``, ``phib``, ``cphi``.
    bounds : dict
        Keyword arguments for :func:`uncertain` (``k`` times the standard deviations).
    tables : dict
        ``gamma_std_over_mean``, ``gamma_pct_pd_bound`` (% of ``sqrt(g_ii g_jj)``),
        ``omega_std_over_mean``, ``mac`` (MAC of each aligned mode to the reference).
    aligned : list of NormalModeModel
        The models with modes reordered and re-signed.
    """

    mean: object
    std: dict
    bounds: dict
    tables: dict
    aligned: list

    def __repr__(self) -> str:
        mac = np.asarray(self.tables.get("mac", np.ones(1)))
        return one_line("MultiTestResult", [
            f"{len(self.aligned)} models", f"n={self.mean.n}", f"ns={self.mean.ns}",
            f"na={self.mean.na}", f"min MAC={mac.min():.3f}" if mac.size else ""])


def _align(ref, m):
    """Reorder and re-sign the modes of ``m`` to match ``ref`` by MAC of ``cphi`` columns."""
    from scipy.optimize import linear_sum_assignment
    a, b = np.asarray(ref.cphi), np.asarray(m.cphi)
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, 0), np.sum(np.abs(b) ** 2, 0))
    mac = num / np.where(den > 0, den, 1.0)
    _, perm = linear_sum_assignment(-mac)
    sgn = np.sign(np.real(np.sum(a * b[:, perm], axis=0)))
    sgn[sgn == 0] = 1.0
    S = np.diag(sgn)
    P = np.eye(len(perm))[:, perm]
    T = P @ S
    sd = getattr(m, "std", None)           # standard deviations: permuted, never signed
    std = None if sd is None else {"Omega": sd["Omega"][np.ix_(perm, perm)],
                                   "Gamma": sd["Gamma"][np.ix_(perm, perm)],
                                   "phib": sd["phib"][perm], "cphi": sd["cphi"][:, perm]}
    return m.replace(Omega=T.T @ m.Omega @ T, Gamma=T.T @ m.Gamma @ T,
                     phib=T.T @ m.phib, cphi=m.cphi @ T, std=std), mac[np.arange(len(perm)), perm]


def multi_test_statistics(models, reference: int = 0, k: float = 1.0) -> MultiTestResult:
    """Statistics of several identified models of one structure (section 5.2.3).

    Modes are aligned on ``models[reference]`` (order and sign by MAC of ``cphi``), then the mean
    model and the sample standard deviation of each parameter are computed.

    Parameters
    ----------
    models : sequence of NormalModeModel
        At least two models with the same numbers of modes, sensors and actuators.
    reference : int
        Index of the model whose mode order and signs are used.
    k : float
        Bounds are ``k`` times the standard deviations.

    Returns
    -------
    MultiTestResult
    """
    models = list(models)
    if len(models) < 2:
        raise ValueError("models must hold at least two NormalModeModels")
    ref = models[reference]
    aligned, macs = [], []
    for m in models:
        if (m.n, m.ns, m.na) != (ref.n, ref.ns, ref.na):
            raise ValueError("models must share n, ns, na")
        a, mac = _align(ref, m)
        aligned.append(a)
        macs.append(mac)
    stack = {key: np.array([getattr(a, key) for a in aligned], float)
             for key in ("Omega", "Gamma", "phib", "cphi")}
    mean = {k_: v.mean(0) for k_, v in stack.items()}
    std = {k_: v.std(0, ddof=1) for k_, v in stack.items()}
    mean_model = ref.replace(Omega=0.5 * (mean["Omega"] + mean["Omega"].T),
                             Gamma=0.5 * (mean["Gamma"] + mean["Gamma"].T),
                             phib=mean["phib"], cphi=mean["cphi"])
    with np.errstate(divide="ignore", invalid="ignore"):
        g_rel = std["Gamma"] / np.abs(mean["Gamma"])
        o_rel = std["Omega"] / np.abs(mean["Omega"])
        pd = np.sqrt(np.outer(np.abs(np.diag(mean["Gamma"])), np.abs(np.diag(mean["Gamma"]))))
        g_pd = 100.0 * std["Gamma"] / pd
    np.fill_diagonal(g_pd, np.nan)
    bounds = {"dGamma": k * std["Gamma"], "dOmega": k * std["Omega"], "db": k * std["phib"],
              "dc": k * std["cphi"]}
    tables = {"gamma_std_over_mean": g_rel, "gamma_pct_pd_bound": g_pd,
              "omega_std_over_mean": o_rel, "mac": np.array(macs)}
    return MultiTestResult(mean_model, std, bounds, tables, aligned)
