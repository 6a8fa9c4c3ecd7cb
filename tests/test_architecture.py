"""Layout rules: public functions are plain functions, never modules made callable."""

import importlib.util
import inspect
import pickle

import pytest

import sdctrl as sd


@pytest.mark.parametrize("name", sorted(sd.__all__))
def test_no_module_is_named_like_a_public_name(name):
    assert importlib.util.find_spec(f"sdctrl.{name}") is None, (
        f"sdctrl.{name} is a module: sd.{name} would depend on import order")


@pytest.mark.parametrize("name", ["identify", "hybrid", "testbed", "normal_modes", "rms"])
def test_public_functions_are_plain_and_picklable(name):
    func = getattr(sd, name)
    assert inspect.isfunction(func)
    assert not inspect.ismodule(func)
    assert pickle.loads(pickle.dumps(func)) is func
    assert inspect.getdoc(func).strip()
    assert "Help on module" not in (func.__doc__ or "")
