"""Storable types of FE updating (thesis chapter IV): parameters, the element record of an
assembled FE model, reduced models, :class:`~sdctrl.updating._update_fit.UpdateResult` and
:class:`~sdctrl.updating._identifiability.Identifiability` (registered on import).

Their classes are plain dataclasses that trust their callers; a file may be hostile, so each
builder here checks what it is given (types, shapes, finiteness, index ranges) and raises
``ValueError``/``TypeError`` before building.
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from sdctrl.storage._registry import register_attrs
from sdctrl.storage._values import short

__all__: list[str] = []


def _fail(what: str, value) -> ValueError:
    return ValueError(f"{what} is malformed: {short(value)}")


def _array(a, what: str, kind: str, shape: tuple, finite: bool = True) -> np.ndarray:
    """``a`` as a read-only array of dtype kind ``kind`` and ``shape`` (None: free)."""
    if not isinstance(a, np.ndarray) or a.dtype.kind not in kind or a.ndim != len(shape) or any(
            s is not None and s != n for s, n in zip(shape, a.shape)):
        raise _fail(what, a)
    if finite and a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must hold finite values")
    a = np.array(a)
    a.setflags(write=False)
    return a


def _number(v, what: str, finite: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or (finite and not math.isfinite(v)):
        raise _fail(what, v)
    return float(v)


def _names(v, what: str) -> tuple:
    if not isinstance(v, tuple) or not all(isinstance(s, str) for s in v):
        raise _fail(what, v)
    return v


def _float_dict(v, names, what: str, finite: bool = True) -> dict:
    if not isinstance(v, dict) or list(v) != list(names):
        raise _fail(what, v)
    return {k: _number(x, f"{what}[{k!r}]", finite) for k, x in v.items()}


def _properties(v, what: str) -> MappingProxyType:
    """Material or section properties: name -> {property: number}."""
    if not isinstance(v, dict) or not all(isinstance(p, dict) for p in v.values()):
        raise _fail(what, v)
    return MappingProxyType({k: MappingProxyType({q: _number(x, f"{what}[{k!r}][{q!r}]")
                                                  for q, x in p.items()})
                             for k, p in v.items()})


def _build_assembly(N, names, xyz, gidx, groups, materials, sections, lumped, mass_nodes,
                    mass_values, rayleigh=(0.0, 0.0)):
    """:class:`~sdctrl.fe._groups.Assembly` checked: node table, DOF numbers, element groups
    whose nodes, materials and sections exist, lumped masses on existing nodes, the Rayleigh
    coefficients (files written before they were recorded: none)."""
    from sdctrl.fe._groups import Assembly

    if isinstance(N, bool) or not isinstance(N, int) or N < 1:
        raise _fail("assembly N", N)
    nn = len(_names(names, "assembly names"))
    xyz = _array(xyz, "assembly xyz", "f", (nn, 3))
    gidx = _array(gidx, "assembly gidx", "i", (nn, 6))
    if gidx.size and (gidx.min() < -1 or gidx.max() >= N):
        raise ValueError(f"assembly gidx must hold DOF numbers in [-1, {N})")
    mats, secs = _properties(materials, "assembly materials"), _properties(sections,
                                                                           "assembly sections")
    if not isinstance(groups, tuple):
        raise _fail("assembly groups", groups)
    out = []
    for g in groups:
        ok = isinstance(g, tuple) and len(g) == 2 and isinstance(g[0], tuple) and len(g[0]) == 4
        key = g[0] if ok else None
        ok = ok and key[0] in ("bar", "beam") and key[1] in mats and key[2] in secs and (
            key[3] is None or (isinstance(key[3], tuple) and len(key[3]) == 3 and all(
                isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
                for x in key[3])))
        if not ok:
            raise _fail("assembly group", g)
        conn = _array(g[1], "assembly connectivity", "i", (None, 2))
        if conn.size and (conn.min() < 0 or conn.max() >= nn):
            raise ValueError(f"assembly connectivity must hold node indices in [0, {nn})")
        out.append((key, conn))
    if not isinstance(lumped, bool):
        raise _fail("assembly lumped", lumped)
    mass_nodes = _array(mass_nodes, "assembly mass_nodes", "i", (None,))
    if mass_nodes.size and (mass_nodes.min() < 0 or mass_nodes.max() >= nn):
        raise ValueError(f"assembly mass_nodes must hold node indices in [0, {nn})")
    mass_values = _array(mass_values, "assembly mass_values", "f", (mass_nodes.size, 6))
    if not isinstance(rayleigh, tuple) or len(rayleigh) != 2:
        raise _fail("assembly rayleigh", rayleigh)
    ray = tuple(_number(v, "assembly rayleigh") for v in rayleigh)
    if min(ray) < 0:
        raise _fail("assembly rayleigh", rayleigh)
    return Assembly(N, names, xyz, gidx, tuple(out), mats, secs, lumped, mass_nodes,
                    mass_values, ray)


def _build_reduced(Mr, Cr, Kr, dM, dC, dK, c, b, names):
    """:class:`~sdctrl.updating._parametric.ReducedModel` with consistent shapes."""
    from sdctrl.updating._parametric import ReducedModel

    npar = len(_names(names, "reduced model names"))
    n = Kr.shape[0] if isinstance(Kr, np.ndarray) and Kr.ndim == 2 else -1
    square = {k: _array(v, f"reduced model {k}", "f", (n, n))
              for k, v in (("Mr", Mr), ("Cr", Cr), ("Kr", Kr))}
    stacks = {k: _array(v, f"reduced model {k}", "f", (npar, n, n))
              for k, v in (("dM", dM), ("dC", dC), ("dK", dK))}
    return ReducedModel(**square, **stacks, c=_array(c, "reduced model c", "f", (None, n)),
                        b=_array(b, "reduced model b", "f", (n, None)), names=names)


def _parameters(v, what: str, names=None) -> tuple:
    from sdctrl.fe._parameters import Parameter

    if not isinstance(v, tuple) or not all(isinstance(p, Parameter) for p in v) or (
            names is not None and tuple(p.name for p in v) != tuple(names)):
        raise _fail(what, v)
    return v


def _build_cost_problem(rm, omega, logH, parameters):
    """:class:`~sdctrl.updating._identifiability.CostProblem`: the data fits the reduced model."""
    from sdctrl.updating._parametric import ReducedModel
    from sdctrl.updating._identifiability import CostProblem

    if not isinstance(rm, ReducedModel):
        raise _fail("cost problem rm", rm)
    omega = _array(omega, "cost problem omega", "f", (None,))
    if np.any(omega <= 0):
        raise ValueError("cost problem omega must be positive")
    logH = _array(logH, "cost problem logH", "f", (omega.size, rm.c.shape[0], rm.b.shape[1]))
    return CostProblem(rm, omega, logH, _parameters(parameters, "cost problem parameters",
                                                    rm.names))


def _build_update(values, fe, cost_before, cost_after, parameters, pairing, stages, model,
                  info=None, damping=None, test_modes=None, std=None, fit=None):
    """:class:`~sdctrl.updating._update_fit.UpdateResult` checked field by field."""
    from sdctrl.fe import FEModel
    from sdctrl.modal._normal_model import NormalModeModel
    from sdctrl.updating._fit_floor import FitFloor
    from sdctrl.updating._update_fit import UpdateResult

    pars = _parameters(parameters, "update parameters")
    values = _float_dict(values, [p.name for p in pars], "update values")
    if not isinstance(fe, FEModel) or any(p.N != fe.N for p in pars):
        raise _fail("update fe", fe)
    if model is not None and not isinstance(model, NormalModeModel):
        raise _fail("update model", model)
    if not isinstance(pairing, dict) or not all(
            isinstance(k, str) and isinstance(a, np.ndarray) and a.ndim == 1
            for k, a in pairing.items()):
        raise _fail("update pairing", pairing)
    if not isinstance(stages, tuple) or not all(
            isinstance(s, dict) and set(s) == {"stage", "values", "cost", "nfev"}
            and isinstance(s["stage"], str) for s in stages):
        raise _fail("update stages", stages)
    for s in stages:
        _array(s["values"], "update stage values", "f", (len(pars),))
        _number(s["cost"], "update stage cost", finite=False)
    info = {} if info is None else dict(info)
    if damping is None and test_modes is None:   # sdctrl 0.1: the sources were in info
        damping, test_modes = info.pop("damping", None), info.pop("test_modes", None)
    for name, text in (("damping", damping), ("test_modes", test_modes)):
        if text is not None and not isinstance(text, str):
            raise _fail(f"update {name}", text)
    std = {} if std is None else _float_dict(std, [p.name for p in pars], "update std", False)
    if fit is not None and not isinstance(fit, FitFloor):
        raise _fail("update fit", fit)
    return UpdateResult(values, fe, _number(cost_before, "update cost_before", False),
                        _number(cost_after, "update cost_after", False), pars, pairing,
                        stages, model, info, damping=damping, test_modes=test_modes, std=std,
                        fit=fit)


def _build_identifiability(names, sensitivity, correlation, confounded, weak, error_level,
                           error_source, standard_change, separation, problem, std=None,
                           estimate_correlation=None):
    """:class:`~sdctrl.updating._identifiability.Identifiability` checked field by field."""
    from sdctrl.updating._identifiability import CostProblem, Identifiability

    n = len(_names(names, "identifiability names"))
    sens = _float_dict(sensitivity, names, "identifiability sensitivity")
    change = _float_dict(standard_change, names, "identifiability standard_change")
    corr = _array(correlation, "identifiability correlation", "f", (n, n))
    sep = _array(separation, "identifiability separation", "f", (n, n), finite=False)
    pairs_ok = isinstance(confounded, list) and all(
        isinstance(p, tuple) and len(p) == 2 and p[0] in names and p[1] in names
        for p in confounded)
    if not pairs_ok or not isinstance(weak, list) or not set(weak) <= set(names):
        raise _fail("identifiability confounded/weak", (confounded, weak))
    if not isinstance(error_source, str) or not isinstance(problem, CostProblem) or \
            problem.rm.names != names:
        raise _fail("identifiability problem", problem)
    pstd = {} if std is None else _float_dict(std, names, "identifiability std", False)
    ecorr = None if estimate_correlation is None else _array(
        estimate_correlation, "identifiability estimate_correlation", "f", (n, n), finite=False)
    return Identifiability(names, sens, corr, confounded, weak,
                           _number(error_level, "identifiability error_level"), error_source,
                           change, sep, problem, pstd, ecorr)


register_attrs("Parameter", "sdctrl.fe._parameters:Parameter",
               kinds={"dM": "f", "dK": "f", "dC": "f"})
register_attrs("Assembly", "sdctrl.fe._groups:Assembly",
               kinds={"xyz": "f", "gidx": "i", "mass_nodes": "i", "mass_values": "f"},
               build=_build_assembly, lenient=())
register_attrs("ReducedModel", "sdctrl.updating._parametric:ReducedModel",
               kinds={k: "f" for k in ("Mr", "Cr", "Kr", "dM", "dC", "dK", "c", "b")},
               build=_build_reduced, lenient=())
register_attrs("CostProblem", "sdctrl.updating._identifiability:CostProblem",
               kinds={"omega": "f", "logH": "f"}, build=_build_cost_problem, lenient=())
register_attrs("FitFloor", "sdctrl.updating._fit_floor:FitFloor")
register_attrs("UpdateResult", "sdctrl.updating._update_fit:UpdateResult", build=_build_update)
register_attrs("Identifiability", "sdctrl.updating._identifiability:Identifiability",
               kinds={"correlation": "f", "separation": "f", "estimate_correlation": "f"},
               build=_build_identifiability,
               lenient=())
