"""Every public function and method documents every parameter (numpydoc), the habit of
python-control's docstrings test: the docs never fall behind the code."""

import dataclasses
import inspect
import re

import pytest

import sdctrl as sd

_SECTION = re.compile(r"^\s*([A-Z][A-Za-z ]+)\n\s*-{3,}\s*$", re.MULTILINE)


def _documented(doc: str) -> set[str]:
    doc = inspect.cleandoc(doc or "")
    m = re.search(r"^Parameters\n-{3,}\n(.*?)(?=^\S[^\n]*\n-{3,}|\Z)", doc, re.MULTILINE | re.DOTALL)
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


def _public_callables():
    out = []
    for name in sd.__all__:
        try:
            obj = getattr(sd, name)
        except (ImportError, AttributeError) as exc:      # reported by test_public_names_resolve
            out.append((name, f"cannot import: {exc}", ["<unresolved>"]))
            continue
        if inspect.isclass(obj):
            fields = ([f.name for f in dataclasses.fields(obj) if f.init and f.name != "info"]
                      if dataclasses.is_dataclass(obj) else _params(obj.__init__))
            out.append((name, obj.__doc__, fields))
            for mname, meth in vars(obj).items():
                if mname.startswith("_") or not callable(meth) or isinstance(meth, type):
                    continue
                func = meth.__func__ if isinstance(meth, classmethod | staticmethod) else meth
                out.append((f"{name}.{mname}", func.__doc__, _params(func)))
        elif callable(obj):
            out.append((name, obj.__doc__, _params(obj)))
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
    for name in sd.__all__:
        assert getattr(sd, name) is not None
    with pytest.raises(AttributeError):
        sd.not_a_name  # noqa: B018
