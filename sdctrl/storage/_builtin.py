"""The built-in storable types: models and results of sdctrl (registered on import)."""

from __future__ import annotations

import math

import numpy as np

from sdctrl.storage._record_codecs import legacy_complex, legacy_hybrid, legacy_modal
from sdctrl.storage._registry import register_attrs
from sdctrl.storage._values import short

__all__: list[str] = []


def _build_uncertain(model, dGamma, dOmega, db, dc, params=(), source="", dpoles=None,
                     dresidues=None):
    """UncertainModel from stored fields, checked as :func:`sdctrl.robust._uncertainty.uncertain`
    builds them (the dataclass itself does not validate)."""
    from sdctrl.modal._normal_model import NormalModeModel
    from sdctrl.robust._uncertainty import UncertainModel

    if not isinstance(model, NormalModeModel):
        raise TypeError(f"model must be a NormalModeModel, got {type(model).__name__}")
    n, ns, na = model.n, model.ns, model.na
    shapes = {"dGamma": (n, n), "dOmega": (n, n), "db": (n, na), "dc": (ns, n)}
    bounds = {"dGamma": dGamma, "dOmega": dOmega, "db": db, "dc": dc}
    for k, a in bounds.items():
        if not isinstance(a, np.ndarray) or a.shape != shapes[k] or a.dtype.kind != "f" \
                or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ValueError(f"{k} must be finite non-negative bounds of shape {shapes[k]}")
    if not isinstance(params, list):
        raise TypeError("params must be a list")
    limits = {"Omega": (n, n), "Gamma": (n, n), "b": (n, na), "c": (ns, n)}
    reps = dict.fromkeys(limits, (1, 2))
    if dresidues is not None or dpoles is not None:
        m = _check_residual_bounds(model, dpoles, dresidues)
        limits.update({"rsig": (m, 1), "romg": (m, 1), "rre": (m, ns * na), "rim": (m, ns * na)})
        reps.update({"rsig": (2 * na,), "romg": (2 * na,), "rre": (1,), "rim": (1,)})
    for p in params:
        ok = isinstance(p, tuple) and len(p) == 4 and isinstance(p[0], str) \
            and isinstance(p[1], tuple) and len(p[1]) == 3 and p[1][0] in limits \
            and p[2] in reps[p[1][0]] and not isinstance(p[2], bool) \
            and isinstance(p[3], float) and math.isfinite(p[3]) and p[3] >= 0
        ok = ok and all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < lim
                        for i, lim in zip(p[1][1:], limits[p[1][0]]))
        if not ok:
            raise ValueError(f"malformed uncertain parameter {short(p)}")
    if not isinstance(source, str):
        raise TypeError("source must be a string")
    return UncertainModel(model, dGamma, dOmega, db, dc, params, source, dpoles, dresidues)


def _check_residual_bounds(model, dpoles, dresidues) -> int:
    """Number of residual poles the stored bounds ``dpoles``/``dresidues`` describe."""
    res = model.residual
    if res is None:
        raise ValueError("dpoles/dresidues bound residual dynamics the model does not have")
    shapes = {"dpoles": (res.m,), "dresidues": (res.m, model.ns, model.na)}
    for k, a in (("dpoles", dpoles), ("dresidues", dresidues)):
        if not isinstance(a, np.ndarray) or a.shape != shapes[k] or a.dtype.kind != "c" \
                or not np.all(np.isfinite(a)) or np.any(a.real < 0) or np.any(a.imag < 0):
            raise ValueError(f"{k} must be finite non-negative complex bounds of shape "
                             f"{shapes[k]}")
    return res.m


def _build_fit_stats(S, A_inv, M, K, V, model="complex", asymptotic=(True, True),
                     noise="residual"):
    """FitStatistics from stored fields, shapes and options checked (files may be hostile)."""
    from sdctrl.identification._pole_statistics import FitStatistics

    arrays = {"S": S, "A_inv": A_inv, "M": M, "K": K, "V": V}
    if not all(isinstance(a, np.ndarray) and np.all(np.isfinite(a)) for a in arrays.values()):
        raise ValueError("FitStatistics arrays must be finite arrays")
    n2, (m, q) = S.shape[0], V.shape[:2]
    shapes = {"S": (n2, n2), "A_inv": (n2, n2), "M": (m, q, n2), "K": (m, q, n2),
              "V": (m, q, q)}
    for k, a in arrays.items():
        if a.shape != shapes[k]:
            raise ValueError(f"FitStatistics {k} must have shape {shapes[k]}, got {a.shape}")
    if model not in ("complex", "real") or noise not in ("coherence", "residual") or \
            not (isinstance(asymptotic, tuple) and len(asymptotic) == 2
                 and all(isinstance(a, bool) for a in asymptotic)):
        raise ValueError("malformed FitStatistics options")
    return FitStatistics(S, A_inv, M, K, V, model, asymptotic, noise)


def _build_robust(**values):
    from sdctrl.robust._stability import RobustResult

    for k in ("margin", "margin_lower", "frequency"):
        if k in values and (isinstance(values[k], bool) or not isinstance(values[k], int | float)):
            raise TypeError(f"{k} must be a number")
    info = values.get("info")
    if "certified" not in values and isinstance(info, dict) and "certified" in info:
        info = dict(info)                    # a file of sdctrl 0.1: the flag was in info
        values = {**values, "info": info, "certified": info.pop("certified")}
    for k in ("stable", "certified"):
        if k in values and not isinstance(values[k], bool):
            raise TypeError(f"{k} must be a bool")
    return RobustResult(**values)


_MODAL = {k: "f" for k in ("Omega", "Gamma", "cphi", "phib", "E", "F", "shapes",
                            "transformation")}


def _build_complex(**values):
    from sdctrl.identification._complex_modes import ComplexModeModel

    return ComplexModeModel(**legacy_complex(values))


def _build_normal(**values):
    from sdctrl.modal._normal_model import NormalModeModel

    return NormalModeModel(**legacy_modal(values))


def _build_hybrid(**values):
    from sdctrl.hybrids._predictions import HybridModel

    return HybridModel(**legacy_hybrid(values))


register_attrs("FRF", "sdctrl.data._frf:FRF",
               ("freq", "H", "quantity", "sensors", "actuators", "collocated", "coherence",
                "units", "exponential_tau", "averages"),
               kinds={"freq": "f", "H": "c", "coherence": "f"})
register_attrs("ComplexModeModel", "sdctrl.identification:ComplexModeModel",
               kinds={"poles": "c", "residues": "c", "E": "f", "F": "f", "in_band": "b"},
               build=_build_complex)
register_attrs("FitStatistics", "sdctrl.identification._pole_statistics:FitStatistics",
               kinds={k: "f" for k in ("S", "A_inv", "M", "K", "V")}, build=_build_fit_stats)
register_attrs("NormalModeModel", "sdctrl.modal._normal_model:NormalModeModel", kinds=_MODAL,
               build=_build_normal)
register_attrs("ResidualDynamics", "sdctrl.modal._residual_dynamics:ResidualDynamics",
               kinds={"poles": "c", "residues": "c", "source": "i", "pole_std": "c",
                      "residue_std": "c"})
register_attrs("HybridModel", "sdctrl.hybrids._predictions:HybridModel", kinds=_MODAL,
               build=_build_hybrid)
register_attrs("FEModel", "sdctrl.fe:FEModel",
               ("M", "K", "C", "dofs", "nodes", "elements", "assembly"),
               kinds={"M": "f", "K": "f", "C": "f"})
register_attrs("UncertainModel", "sdctrl.robust._uncertainty:UncertainModel",
               kinds={"dGamma": "f", "dOmega": "f", "db": "f", "dc": "f", "dpoles": "c",
                      "dresidues": "c"},
               build=_build_uncertain, lenient=())
register_attrs("RobustResult", "sdctrl.robust._stability:RobustResult",
               kinds={"worst_delta": "f", "mu_freq": "f", "mu": "f"}, build=_build_robust)
register_attrs("Effect", "sdctrl.diagnosis:Effect")
