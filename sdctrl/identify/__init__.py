"""Chapter III of the thesis: complex-mode identification and normal modes from complex modes.

Public names are resolved lazily from the submodules:
``initial_poles`` (poles.py), ``identify`` (optimize.py), ``ComplexModeModel``
(complex_modes.py), ``normal_modes`` (proper.py).

``sdctrl.identify`` is both this package and the public function of the same name
(API.md: ``sd.identify(frf, poles=None, band=None)``): calling the package calls
:func:`sdctrl.identify.optimize.identify`, so ``sd.identify(frf)`` works whichever of the
two the attribute resolves to.
"""

from __future__ import annotations

import importlib
import sys
import types

_EXPORTS = {
    "initial_poles": "sdctrl.identify.poles",
    "identify": "sdctrl.identify.optimize",
    "ComplexModeModel": "sdctrl.identify.complex_modes",
    "normal_modes": "sdctrl.identify.proper",
}

__all__ = ["ComplexModeModel", "identify", "initial_poles", "normal_modes"]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl.identify' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


_PACKAGE_DOC = __doc__


class _CallablePackage(types.ModuleType):
    """The package, callable as :func:`sdctrl.identify.optimize.identify`.

    ``help(sd.identify)`` and ``inspect.signature(sd.identify)`` show the function's
    documentation and signature.
    """

    def __call__(self, *args, **kwargs):
        from sdctrl.identify.optimize import identify

        return identify(*args, **kwargs)

    @property
    def __doc__(self):
        from sdctrl.identify.optimize import identify

        return identify.__doc__ + "\n    Package notes\n    -------------\n" + "\n".join(
            "    " + line for line in _PACKAGE_DOC.splitlines())

    @property
    def __signature__(self):
        import inspect

        from sdctrl.identify.optimize import identify

        return inspect.signature(identify)


sys.modules[__name__].__class__ = _CallablePackage
