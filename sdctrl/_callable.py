"""Modules that share their name with their main function (internal).

``sdctrl.testbed`` and ``sdctrl.hybrid`` name both a submodule and the public function
it defines.  Importing the submodule binds the *module* to the package attribute, so the
module is made callable: ``sd.hybrid(fe, nm, c)`` works whichever object the name
resolves to, and the module carries the function's signature.
"""

from __future__ import annotations

import inspect
import sys
import types


class CallableModule(types.ModuleType):
    """A module whose call is its function of the same name."""

    def __call__(self, *args, **kwargs):
        return getattr(self, self.__name__.rsplit(".", 1)[-1])(*args, **kwargs)


def make_callable(module_name: str) -> None:
    """Make the module ``module_name`` callable as its function of the same name."""
    mod = sys.modules[module_name]
    func = getattr(mod, module_name.rsplit(".", 1)[-1])
    mod.__class__ = CallableModule
    mod.__signature__ = inspect.signature(func)
