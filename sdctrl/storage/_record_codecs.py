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

__all__ = ["from_info", "legacy_modal"]


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


register_attrs("Properness", "sdctrl.identification._proper:Properness")
