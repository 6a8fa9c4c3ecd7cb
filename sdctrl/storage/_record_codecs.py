"""Typed result records of sdctrl and the mapping of older files onto them.

Results that callers read are typed fields (:class:`~sdctrl.identification._proper.Properness`
of ``sd.normal_modes``, the fit diagnostics of ``sd.identify``, the construction of a hybrid
model...).  Files written by sdctrl 0.1 kept them as keys of the models' ``info`` dicts: the
builders here move those entries onto the new fields (a field the old file has no value for
stays None) so that old files load with the same numbers.
"""

from __future__ import annotations

from dataclasses import fields

from sdctrl.storage._registry import register_attrs

__all__ = ["from_info", "legacy_complex", "legacy_hybrid", "legacy_modal"]


def from_info(info: dict, record: type, rename: dict | None = None):
    """A ``record`` built from (and taken out of) the entries of an old ``info`` dict.

    Parameters
    ----------
    info : dict
        The old diagnostics; the entries used are removed from it.
    record : type
        A dataclass whose fields default to None.
    rename : dict of str to str, optional
        Old key -> field name, for keys that were renamed.

    Returns
    -------
    record or None
        None when ``info`` holds none of the record's entries.
    """
    names = {f.name for f in fields(record) if f.init}
    keys = {k: k for k in names} | dict(rename or {})
    found = {keys[k]: info.pop(k) for k in list(info) if k in keys}
    return record(**found) if found else None


def legacy_modal(values: dict) -> dict:
    """Fields of a NormalModeModel (or hybrid) with its sdctrl 0.1 ``info`` entries mapped.

    ``info`` entries of :func:`sdctrl.normal_modes` become ``properness``; ``n_static`` and
    ``transformation`` become the fields of the same names.

    Parameters
    ----------
    values : dict
        Stored fields.

    Returns
    -------
    dict
    """
    from sdctrl.identification._proper import Properness

    if not isinstance(values.get("info"), dict):
        return values
    values = dict(values)
    info = dict(values["info"])
    if values.get("properness") is None and "properness" not in values:
        values["properness"] = from_info(info, Properness)
    for key in ("n_static", "transformation"):
        if key in info and key not in values:
            values[key] = info.pop(key)
    values["info"] = info
    return values


def legacy_complex(values: dict) -> dict:
    """Fields of a ComplexModeModel with its sdctrl 0.1 ``info`` entries mapped.

    ``stabilisation`` (a dict of orders and poles) and ``warnings`` become the fields of
    those names; the fit diagnostics (optimiser, evaluations, compression, the last
    search's convergence, interruption) become ``search``.

    Parameters
    ----------
    values : dict
        Stored fields.

    Returns
    -------
    dict
    """
    from sdctrl.identification._fit_records import SearchDiagnostics, Stabilisation

    if not isinstance(values.get("info"), dict) or "search" in values:
        return values
    values, info = dict(values), dict(values["info"])
    stab = info.pop("stabilisation", None)
    if isinstance(stab, dict):
        values["stabilisation"] = Stabilisation(stab.get("orders"), tuple(stab.get("poles", ())))
    if "warnings" in info:
        values["warnings"] = tuple(info.pop("warnings"))
    last = info.pop("search", None)
    search = from_info(info, SearchDiagnostics)
    if isinstance(last, dict):
        search = SearchDiagnostics(**{**vars(search or SearchDiagnostics()), **{
            k: last[k] for k in ("converged", "status", "message") if k in last}})
    values["search"] = search
    values["info"] = info
    return values


def legacy_hybrid(values: dict) -> dict:
    """Fields of a HybridModel with its sdctrl 0.1 ``info`` entries mapped.

    ``kind`` becomes the field of that name (``measured`` is derived from it), the pairing,
    poor pairs, absorbed poles, expansion, residual choice and residual flexibility become
    ``construction``; the rest as :func:`legacy_modal`.

    Parameters
    ----------
    values : dict
        Stored fields.

    Returns
    -------
    dict
    """
    from sdctrl.hybrids._hybrid_records import HybridConstruction, ModePairing, ResidualChoice

    values = legacy_modal(values)
    if not isinstance(values.get("info"), dict) or "construction" in values:
        return values
    info = dict(values["info"])
    if "kind" in info and "kind" not in values:
        values["kind"] = info.pop("kind")
    info.pop("measured", None)
    pairing, poor = info.pop("pairing", None), info.pop("poor_pairs", None)
    residual, kappa = info.pop("residual", None), info.pop("kappa", None)
    if isinstance(residual, dict):
        residual = ResidualChoice(**residual)
    elif kappa is not None:
        residual = ResidualChoice(kappa=kappa)
    built = from_info(info, HybridConstruction)
    if pairing is not None or residual is not None or built is not None:
        pairing = None if pairing is None else ModePairing(**pairing, poor=poor)
        built = built or HybridConstruction()
        values["construction"] = HybridConstruction(**{**vars(built), "pairing": pairing,
                                                       "residual": residual})
    values["info"] = info
    return values


register_attrs("Stabilisation", "sdctrl.identification._fit_records:Stabilisation")
register_attrs("SearchDiagnostics", "sdctrl.identification._fit_records:SearchDiagnostics")
register_attrs("Properness", "sdctrl.identification._properness_record:Properness")
register_attrs("CollocatedPassivity",
               "sdctrl.identification._collocated_passivity:CollocatedPassivity")
register_attrs("ModePairing", "sdctrl.hybrids._hybrid_records:ModePairing")
register_attrs("ResidualChoice", "sdctrl.hybrids._hybrid_records:ResidualChoice")
register_attrs("OutOfBandTrial", "sdctrl.hybrids._hybrid_records:OutOfBandTrial")
register_attrs("MassScale", "sdctrl.hybrids._hybrid_records:MassScale")
register_attrs("HybridConstruction", "sdctrl.hybrids._hybrid_records:HybridConstruction")
