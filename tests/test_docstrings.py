"""Every public function and method documents every parameter (numpydoc), the habit of
python-control's docstrings test: the docs never fall behind the code."""

import dataclasses
import importlib
import inspect
import pathlib
import re

import pytest

import sdctrl as sd

_SECTION = re.compile(r"^\s*([A-Z][A-Za-z ]+)\n\s*-{3,}\s*$", re.MULTILINE)


def _documented(doc: str) -> set[str]:
    doc = inspect.cleandoc(doc or "")
    m = re.search(r"^Parameters\n-{3,}\n(.*?)(?=^\S[^\n]*\n-{3,}|\Z)", doc,
                  re.MULTILINE | re.DOTALL)
    if not m:
        return set()
    names = set()
    for line in m.group(1).splitlines():
        if line and not line.startswith(" "):
            head = line.split(" : ")[0].split(":")[0]
            for name in head.split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _params(obj) -> list[str]:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return []
    return [p.name for p in sig.parameters.values()
            if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]


def _public_modules():
    """The top level and every public module (no ``_`` in its path) that defines ``__all__``."""
    root = pathlib.Path(sd.__file__).resolve().parent
    out = [sd]
    for path in sorted(root.rglob("*.py")):
        parts = ("sdctrl",) + path.relative_to(root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if len(parts) == 1 or any(p.startswith("_") for p in parts[1:]):
            continue
        mod = importlib.import_module(".".join(parts))
        if hasattr(mod, "__all__"):
            out.append(mod)
    return out


def _entries(qual, obj):
    if inspect.isclass(obj):
        fields = ([f.name for f in dataclasses.fields(obj) if f.init and f.name != "info"]
                  if dataclasses.is_dataclass(obj) else _params(obj.__init__))
        yield qual, obj.__doc__, fields
        for mname, meth in vars(obj).items():
            if mname.startswith("_") or not callable(meth) or isinstance(meth, type):
                continue
            func = meth.__func__ if isinstance(meth, classmethod | staticmethod) else meth
            yield f"{qual}.{mname}", func.__doc__, _params(func)
    elif callable(obj):
        yield qual, obj.__doc__, _params(obj)


def _public_callables():
    out, seen = [], set()
    for mod in _public_modules():
        for name in mod.__all__:
            qual = f"{mod.__name__}.{name}"
            try:
                obj = getattr(mod, name)
            except (ImportError, AttributeError) as exc:  # reported by test_public_names_resolve
                out.append((qual, f"cannot import: {exc}", ["<unresolved>"]))
                continue
            if inspect.ismodule(obj) or id(obj) in seen:
                continue
            seen.add(id(obj))
            out.extend(_entries(qual, obj))
    return out


@pytest.mark.parametrize("qualname, doc, params", _public_callables(),
                         ids=[c[0] for c in _public_callables()])
def test_every_parameter_documented(qualname, doc, params):
    assert doc and doc.strip(), f"{qualname} has no docstring"
    if not params:
        return
    documented = _documented(doc)
    missing = [p for p in params if p not in documented]
    assert not missing, f"{qualname}: parameters missing from its docstring: {missing}"


def test_public_names_resolve():
    for mod in _public_modules():
        for name in mod.__all__:
            assert getattr(mod, name) is not None, f"{mod.__name__}.{name}"
    with pytest.raises(AttributeError):
        sd.not_a_name  # noqa: B018
