"""Chapter III of the thesis: complex-mode identification and normal modes from complex modes.

Public names are resolved lazily from the submodules:
``initial_poles`` (poles.py), ``identify`` (optimize.py), ``ComplexModeModel``
(complex_modes.py), ``normal_modes`` (proper.py).
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "initial_poles": "sdctrl.identify.poles",
    "identify": "sdctrl.identify.optimize",
    "ComplexModeModel": "sdctrl.identify.complex_modes",
    "normal_modes": "sdctrl.identify.proper",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl.identify' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
