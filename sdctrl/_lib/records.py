"""Small frozen result records: their arrays are read-only copies, like the models' arrays."""

from __future__ import annotations

from dataclasses import fields

import numpy as np

__all__ = ["freeze_arrays"]


def _frozen(value):
    if isinstance(value, np.ndarray):
        out = np.array(value)
        out.setflags(write=False)
        return out
    if isinstance(value, tuple):
        return tuple(_frozen(v) for v in value)
    return value


def freeze_arrays(record) -> None:
    """Replace each ndarray field of a frozen dataclass (and each array in a tuple field) by
    a read-only copy, so that a record never changes, nor shares memory with its inputs.

    Parameters
    ----------
    record : dataclass instance
        Called from its ``__post_init__``.
    """
    for f in fields(record):
        value = getattr(record, f.name)
        if isinstance(value, np.ndarray | tuple):
            object.__setattr__(record, f.name, _frozen(value))
