"""Accuracy of reduced predictive models over a parameter sweep (thesis 4.3.4, Figure 4.3).

For each value of a parameter the modal frequencies of the modified model are predicted by

- ``"perturbation"``: first-order perturbation (4.19) on the retained normal modes;
- ``"reanalysis"``: the projected model (4.17) on the same normal modes;
- ``"reanalysis+static"``: the projected model on the normal modes augmented with the
  principal static correction modes (4.23)-(4.24) of the parameter's loads,

and compared with the full FE solution.  The full solutions (the expensive part) are
independent: they run on an ``executor`` when one is given.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sdctrl._lib.progress import progress_bar
from sdctrl._lib.display import markdown_table
from sdctrl._lib.validate import check_band, check_executor
from sdctrl.fe._eigen import eigensolve
from sdctrl.fe._parameters import Parameter
from sdctrl.fe._fe_model import check_fe_model
from sdctrl.updating._ritz_basis import reduced_basis
from sdctrl.updating._parametric import perturbation, reduced_model

__all__ = ["ReanalysisErrors", "reanalysis_errors"]

METHODS = ("perturbation", "reanalysis", "reanalysis+static")


@dataclass(frozen=True, eq=False)
class ReanalysisErrors:
    """Modal frequencies of reduced models against the full FE solution over a sweep.

    Parameters
    ----------
    parameter : str
        Parameter name.
    values : ndarray, shape (nv,)
        Swept values of ``p``.
    modes : ndarray of int, shape (k,)
        Indices (in increasing frequency) of the compared modes.
    reference : ndarray, shape (nv, k)
        Full FE frequencies (Hz).
    predictions : dict
        Method -> predicted frequencies (nv, k) in Hz.
    info : dict
        Diagnostics nobody relies on.
    n_modes, n_static : int, optional
        Sizes of the reduced basis: normal modes and static correction modes (4.23).
    """

    parameter: str
    values: np.ndarray
    modes: np.ndarray
    reference: np.ndarray
    predictions: dict
    info: dict = field(default_factory=dict, repr=False)
    n_modes: int | None = None
    n_static: int | None = None

    def __repr__(self) -> str:
        worst = ", ".join(f"{m} {self.max_error(m).max():.2g}" for m in self.predictions)
        return f"ReanalysisErrors({self.parameter!r}, {self.values.size} values; max {worst})"

    def errors(self, method: str) -> np.ndarray:
        """Relative frequency errors ``f_pred / f_full - 1`` (nv, k) of a method.

        Parameters
        ----------
        method : str
            One of :data:`METHODS`.

        Returns
        -------
        ndarray
        """
        if method not in self.predictions:
            raise ValueError(f"method must be one of {tuple(self.predictions)}, got {method!r}")
        return self.predictions[method] / self.reference - 1.0

    def max_error(self, method: str) -> np.ndarray:
        """Largest absolute relative frequency error over the compared modes, per value.

        Parameters
        ----------
        method : str
            One of :data:`METHODS`.

        Returns
        -------
        ndarray, shape (nv,)
        """
        return np.abs(self.errors(method)).max(axis=1)

    def report(self) -> str:
        """Markdown table of the largest relative frequency error per value and method.

        Returns
        -------
        str
        """
        methods = list(self.predictions)
        rows = [[f"{v:.4g}"] + [f"{self.max_error(m)[i]:.2e}" for m in methods]
                for i, v in enumerate(self.values)]
        head = (f"Largest relative error of modes {(self.modes + 1).tolist()} against the full "
                f"FE solution ({self.n_modes} normal modes, "
                f"{self.n_static} static correction modes):")
        return head + "\n\n" + markdown_table([f"p ({self.parameter})"] + methods, rows)


def _full_frequencies(task):
    """Frequencies (Hz) of the lowest modes of ``K + p dK``, ``M + p dM`` (one sweep point)."""
    M, K, dM, dK, p, n, method = task
    if dM is not None:
        M = M + p * dM
    if dK is not None:
        K = K + p * dK
    lam, _ = eigensolve(K, M, n, method)
    return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)


def _reduced_frequencies(rm, lam, values, index):
    """Predictions of the three methods (Hz), each (nv, k)."""
    out = {m: [] for m in METHODS}
    dmu, dOm = rm["modes"].dM[0], rm["modes"].dK[0]
    for p in values:
        w2, _ = perturbation(lam, p * dmu, p * dOm)
        out["perturbation"].append(np.sort(w2))
        out["reanalysis"].append(rm["modes"].modes([p])[0])
        out["reanalysis+static"].append(rm["static"].modes([p])[0])
    return {m: np.sqrt(np.clip(np.array(v)[:, index], 0, None)) / (2 * np.pi)
            for m, v in out.items()}


def reanalysis_errors(fe, parameter: Parameter, values, *, n_modes: int = 25,
                      modes=None, band=None, loads: str = "range", executor=None,
                      progress: bool | None = None) -> ReanalysisErrors:
    """Frequency errors of perturbation and reanalysis against the full FE model (Figure 4.3).

    Parameters
    ----------
    fe : FEModel
        The nominal model.
    parameter : Parameter
        The swept parameter (its ``dC`` is ignored: frequencies are undamped).
    values : array_like
        Values of ``p`` (inside the parameter's bounds).
    n_modes : int
        Normal modes of the nominal model in the reduced bases.
    modes : array_like of int, optional
        Indices of the compared modes (increasing frequency, rigid-body modes included);
        default the first 9 flexible modes, as the thesis's figure.
    band : (float, float), optional
        Instead of ``modes``: the modes whose nominal frequency lies in this band (Hz).
    loads : {"range", "modal"}
        Load shapes of the static correction modes (see
        :func:`sdctrl.updating.reduced_basis`).
    executor : concurrent.futures.Executor, optional
        Runs the full FE solutions (``executor.map``); serial when None.  Results are
        identical either way.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    ReanalysisErrors

    Examples
    --------
    >>> import sdctrl as sd
    >>> from sdctrl.updating import reanalysis_errors
    >>> fe = sd.testbed()
    >>> links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
    >>> e = reanalysis_errors(fe, links, [2.5], band=(8, 60), progress=False)
    >>> bool(e.max_error("reanalysis+static")[0] < e.max_error("perturbation")[0])
    True
    """
    check_fe_model(fe, "fe")
    executor = check_executor(executor)
    if not isinstance(parameter, Parameter):
        raise TypeError(f"parameter must be an sdctrl.Parameter, got {type(parameter).__name__}")
    if parameter.N != fe.N:
        raise ValueError(f"parameter has N={parameter.N}, the model N={fe.N}")
    v = np.atleast_1d(np.asarray(values, float))
    lo, hi = parameter.bounds
    if v.ndim != 1 or not v.size or not np.all(np.isfinite(v)) or np.any((v < lo) | (v > hi)):
        raise ValueError(f"values must be finite values of p within the bounds ({lo:g}, {hi:g})")
    if isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer) or n_modes < 2:
        raise ValueError(f"n_modes must be an integer >= 2, got {n_modes!r}")
    b0 = reduced_basis(fe, n_modes=int(n_modes))
    bs = reduced_basis(fe, [parameter], n_modes=int(n_modes), loads=loads)
    if band is not None:
        flo, fhi = check_band(band, "band")
        index = np.flatnonzero((b0.frequency >= flo) & (b0.frequency <= fhi))
    elif modes is None:
        index = np.arange(b0.n_rigid, min(b0.n_rigid + 9, n_modes))
    else:
        index = np.asarray(modes, int).ravel()
    if index.size == 0 or index.min() < 0 or index.max() >= n_modes:
        raise ValueError(f"modes must be indices below n_modes={n_modes}")
    nfull = int(index.max()) + 1
    rms = {"modes": reduced_model(b0, [parameter], [], []),
           "static": reduced_model(bs, [parameter], [], [])}
    pred = _reduced_frequencies(rms, np.diag(b0.Kr), v, index)
    method = "sparse" if fe.sparse and fe.N > 1200 else "dense"
    tasks = [(fe.M, fe.K, parameter.dM, parameter.dK, float(p), nfull, method) for p in v]
    run = map if executor is None else executor.map
    ref = []
    for f in progress_bar(run(_full_frequencies, tasks), total=v.size, desc="full FE",
                          enabled=progress):
        ref.append(f[index])
    return ReanalysisErrors(parameter.name, v, index, np.array(ref), pred,
                            n_modes=int(n_modes), n_static=bs.n_static)
