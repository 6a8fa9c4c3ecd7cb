"""One progress-bar policy for every long call (internal).

:func:`progress_bar` returns a tqdm bar when bars are wanted and a silent stand-in
otherwise, so callers write the same code either way.  The policy (see
:mod:`sdctrl.config`): an explicit ``enabled`` wins, else ``sdctrl.config.progress``, else
bars only on a terminal or in a notebook.  In a notebook without ipywidgets the plain text
bar is used (no "IProgress not found" warning).
"""

from __future__ import annotations

import sys


def _in_notebook() -> bool:
    shell = sys.modules.get("IPython")
    if shell is None:
        return False
    try:
        ip = shell.get_ipython()
    except AttributeError:
        return False
    return ip is not None and type(ip).__name__ == "ZMQInteractiveShell"


def _has_widgets() -> bool:
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        return False
    return True


def wanted(enabled: bool | None = None) -> bool:
    """Whether a bar is shown: ``enabled`` if given, else the global setting, else auto."""
    if enabled is not None:
        return bool(enabled)
    from sdctrl import config

    if config.progress is not None:
        return bool(config.progress)
    if _in_notebook():
        return True
    stream = sys.stderr
    try:
        return bool(stream is not None and stream.isatty())
    except (AttributeError, ValueError):
        return False


class _Silent:
    """Stand-in with the part of tqdm's interface sdctrl uses."""

    def __init__(self, iterable=None, total=None):
        self.iterable = iterable
        self.total = total
        self.n = 0

    def __iter__(self):
        return iter(self.iterable if self.iterable is not None else ())

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        self.n += n

    def set_postfix_str(self, *args, **kwargs):
        pass

    def set_description_str(self, *args, **kwargs):
        pass

    def refresh(self):
        pass

    def close(self):
        pass


def progress_bar(iterable=None, *, total=None, desc: str | None = None, unit: str = "it",
                 enabled: bool | None = None, leave: bool = False):
    """A tqdm bar (with ``total`` when known) or a silent stand-in, by the policy above."""
    if total is None and iterable is not None and hasattr(iterable, "__len__"):
        total = len(iterable)
    if not wanted(enabled):
        return _Silent(iterable, total)
    if _in_notebook() and _has_widgets():
        from tqdm.notebook import tqdm
    else:
        from tqdm.std import tqdm
    return tqdm(iterable, total=total, desc=desc, unit=unit, leave=leave, file=sys.stderr,
                dynamic_ncols=True)
