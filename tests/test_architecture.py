"""Layout rules: public functions are plain functions, never modules made callable."""

import ast
import importlib.util
import inspect
import pathlib
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


# ----------------------------------------------------------------------------------------
# one-way flow and no private names across modules (DESIGN.md, HELPERS.md "Layout")
# ----------------------------------------------------------------------------------------
ROOT = pathlib.Path(sd.__file__).resolve().parent

#: the flow, left to right: a module imports only modules to its left (or its own package).
#: ``uncertainty`` sits left of ``modal`` so that ``NormalModeModel.uncertain`` can build an
#: ``UncertainModel``; it never imports ``modal`` (see its module docstring).  ``diagnosis``
#: is reserved for ``sd.diagnose``.  A bare ``import sdctrl`` (which re-exports everything)
#: is allowed only at the end of the flow (``LAST``).
ORDER = [
    "sdctrl.config", "sdctrl._validate", "sdctrl._util", "sdctrl._progress", "sdctrl._threads",
    "sdctrl._statespace", "sdctrl._bandint", "sdctrl._files", "sdctrl._npz",
    "sdctrl.frf", "sdctrl.io", "sdctrl.multitest", "sdctrl.uncertainty", "sdctrl._modal_ops",
    "sdctrl.modal", "sdctrl.identification", "sdctrl.fe",
    "sdctrl.updating.costs", "sdctrl.updating.correlation", "sdctrl.updating.expansion",
    "sdctrl.updating.reanalysis", "sdctrl.updating.basis", "sdctrl.updating.parametric",
    "sdctrl.updating.measured", "sdctrl.updating.problem", "sdctrl.updating.fit",
    "sdctrl.updating.sensitivity", "sdctrl.updating.sweep", "sdctrl.updating",
    "sdctrl.predictions", "sdctrl.hybridbasis", "sdctrl.hybridmodel", "sdctrl.testbeds",
    "sdctrl.closedloop", "sdctrl.mu_structure", "sdctrl.mu_lmi", "sdctrl.mu", "sdctrl.mu_sweep",
    "sdctrl.mu_lower", "sdctrl.robust",
    "sdctrl.placement", "sdctrl.testing",
    "sdctrl.diagnosis", "sdctrl.storage", "sdctrl.plot", "sdctrl.report", "sdctrl.story",
    "sdctrl.cli",
]
LAST = ("sdctrl.plot", "sdctrl.report", "sdctrl.story", "sdctrl.cli")


def _modules():
    out = []
    for path in sorted(ROOT.rglob("*.py")):
        parts = ("sdctrl",) + path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), path))
    return out


def _unit(module: str) -> str | None:
    """The entry of ORDER a module belongs to (itself or its package)."""
    best = None
    for u in ORDER:
        if (module == u or module.startswith(u + ".")) and (best is None or len(u) > len(best)):
            best = u
    return best


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def _imports(module: str, path: pathlib.Path):
    """(lineno, imported module, imported name or None) of every sdctrl import, lazy ones too."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "sdctrl":
                    yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "sdctrl":
                continue
            for alias in node.names:
                if _is_module(f"{target}.{alias.name}"):
                    yield node.lineno, f"{target}.{alias.name}", None
                elif target == "sdctrl" and alias.name in sd._EXPORTS:
                    yield node.lineno, sd._EXPORTS[alias.name], alias.name
                else:
                    yield node.lineno, target, alias.name
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "import_module" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and node.args[0].value.startswith("sdctrl")):
            yield node.lineno, node.args[0].value, None


def _violations():
    private, backward, unplaced = [], [], []
    for module, path in _modules():
        if module == "sdctrl":                        # the lazy export table
            continue
        unit = _unit(module)
        if unit is None:
            unplaced.append(module)
            continue
        for line, target, name in _imports(module, path):
            where = f"{path.relative_to(ROOT.parent)}:{line}"
            if (name is not None and name.startswith("_") and not name.startswith("__")
                    and target != module):
                private.append(f"{where} imports private {target}.{name}")
            if target == "sdctrl":
                if name is None and unit not in LAST:
                    backward.append(f"{where} imports the whole package (only {LAST} may)")
                continue
            tunit = _unit(target)
            if tunit is None:
                unplaced.append(target)
            elif tunit != unit and ORDER.index(tunit) > ORDER.index(unit):
                backward.append(f"{where} ({unit}) imports {target}, which sits to its right")
    return private, backward, unplaced


def test_no_private_name_imported_from_another_module():
    private, _, _ = _violations()
    assert not private, "\n".join(private)


def test_flow_is_one_way():
    _, backward, unplaced = _violations()
    assert not unplaced, f"modules missing from ORDER (place them in the flow): {unplaced}"
    assert not backward, "\n".join(backward)


def test_the_checker_sees_violations(tmp_path, monkeypatch):
    """The parser finds lazy imports, relative imports and private names."""
    src = ("def f():\n    from sdctrl.closedloop import _psd\n    from .robust import x\n"
           "    import sdctrl\n")
    p = tmp_path / "modal.py"
    p.write_text(src)
    found = list(_imports("sdctrl.modal", p))
    assert (2, "sdctrl.closedloop", "_psd") in found
    assert (3, "sdctrl.robust", "x") in found
    assert (4, "sdctrl", None) in found
    assert _unit("sdctrl.identification.fit") == "sdctrl.identification"
    assert ORDER.index("sdctrl.uncertainty") < ORDER.index("sdctrl.modal")


def test_dataclasses_never_compare_arrays():
    """Models and results use eq=False (identity) or their own __eq__: ``a == b`` never raises
    "truth value of an array is ambiguous"."""
    import dataclasses

    seen = []
    for module, _ in _modules():
        mod = importlib.import_module(module)
        for obj in vars(mod).values():
            if (inspect.isclass(obj) and dataclasses.is_dataclass(obj)
                    and obj.__module__ == module):
                seen.append(obj)
                generated = obj.__dataclass_params__.eq
                assert not generated, f"{module}.{obj.__name__} compares fields (eq=True)"
    assert len(seen) >= 6


def test_equal_models_compare_without_raising():
    nm = sd.NormalModeModel([[4.0, 0.0], [0.0, 9.0]], [[0.1, 0.01], [0.01, 0.2]],
                            [[1.0, 0.5]], [[1.0], [0.3]])
    u1, u2 = nm.uncertain(dGamma=0.1 * abs(nm.Gamma)), nm.uncertain(dGamma=0.1 * abs(nm.Gamma))
    same = u1
    assert (u1 == u2) is False and (u1 == same) is True and u1 != u2
    assert (nm == nm.replace()) is False
