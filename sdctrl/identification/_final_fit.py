"""The last step of :func:`sdctrl.identify`: the residues of the selected poles on the full
data (3.16), the :class:`~sdctrl.identification.ComplexModeModel` and its statistics
(3.56)-(3.59).

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.validate import QUANTITY_POWER
from sdctrl.identification._fit_records import SearchDiagnostics, Stabilisation
from sdctrl.identification._residues import LSQ, basis, coefficients_to_model, pole_from_params
from sdctrl.identification._variance import statistics_or_none

__all__ = ["FitSpec", "final_model"]


@dataclass(frozen=True, eq=False)
class FitSpec:
    """How the fit is made: parametrisation, asymptotic terms and line weights (None: every
    line alike; :mod:`~sdctrl.identification._line_weights`)."""

    model: str
    asym: tuple
    weight: np.ndarray | None = None


def final_model(data, fband, Hm, poles, spec: FitSpec, info, messages, e=0):
    """Residues of the poles on the full data (3.16) and the :class:`ComplexModeModel`.

    ``Hm`` (nf, ns na) are the data scaled by ``2^-e``; ``poles`` is ``(w, z, side)``.  With
    line weights the least squares are weighted by them; ``cost`` stays the unweighted
    relative error ``||H_fit - H||_F / ||H||_F``.
    """
    from sdctrl.identification._complex_modes import ComplexModeModel

    w, z, side = poles
    _, ns, na = data.H.shape
    order = np.argsort(w)
    w, z, side = w[order], z[order], side[order]
    lam = pole_from_params(w, z)
    Phi = basis(lam, 2j * np.pi * data.freq, QUANTITY_POWER[data.quantity], spec.model,
                spec.asym)
    W = spec.weight
    lsq = LSQ(Phi if W is None else Phi * W[:, None])
    Hw = Hm if W is None else Hm * W[:, None]
    QtY = lsq.project(Hw)
    C = lsq.coefficients(QtY)
    if W is None:
        cost2 = lsq.residual2(Hm, QtY)    # not ||H||^2 - ||Q^T Y||^2: it cancels
    else:
        r = Hm - Phi @ C
        cost2 = float(np.sum(r.real**2) + np.sum(r.imag**2))
    if lsq.rcond < 1e-12:
        messages.append(f"ill-conditioned pole basis (reciprocal condition {lsq.rcond:.2e}): "
                        "poles too close together or too many asymptotic terms")
    info["rcond"] = float(lsq.rcond)
    info["weighting"] = "none" if W is None else "level"
    R, E, F = coefficients_to_model(C, lam, spec.model, spec.asym, ns, na)
    if e:
        R = np.ldexp(R.real, e) + 1j * np.ldexp(R.imag, e)
        E, F = np.ldexp(E, e), np.ldexp(F, e)
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(E)) and np.all(np.isfinite(F))):
            raise ValueError("frf.H: the residues of data this large overflow (largest "
                             f"|H| = 2^{e}); rescale the data")
    normH2 = float(np.sum(Hm.real**2) + np.sum(Hm.imag**2))
    cm = ComplexModeModel(poles=lam, residues=R, E=E, F=F, in_band=side == 0,
                          cost=float(np.sqrt(cost2 / normH2)), sensors=data.sensors,
                          actuators=data.actuators, collocated=data.collocated, band=fband,
                          **_records(info, messages))
    return cm.replace(statistics=statistics_or_none(cm, data))           # (3.56)-(3.59)


def _records(info: dict, messages: list) -> dict:
    """The typed fields of the model (``stabilisation``, ``warnings``, ``search``) from the
    diagnostics gathered during the fit; what remains (the selection log) stays in ``info``."""
    info = dict(info)
    stab = info.pop("stabilisation", None)
    last = info.pop("search", {})
    keys = ("optimizer", "model", "asymptotic", "compress_rank", "compression_residual",
            "lines", "channels", "nfev", "interrupted", "rcond", "weighting",
            "residual_decay")
    search = SearchDiagnostics(**{k: info.pop(k) for k in keys if k in info},
                               converged=bool(last.get("converged", True)),
                               status=last.get("status"), message=last.get("message"))
    return {"info": info, "warnings": tuple(messages), "search": search,
            "stabilisation": None if stab is None else
            Stabilisation(np.asarray(stab["orders"]), tuple(stab["poles"]))}
