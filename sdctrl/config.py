"""Global settings of sdctrl (a plain module: ``sdctrl.config.progress = False``).

progress : bool or None
    Progress bars of long calls (``identify``, ``robust_stability``, ``placement_study``,
    ``update``, ``diagnose``, ...).  ``None`` (default): shown only when standard error is a
    terminal or the code runs in a Jupyter notebook, never in logs, pipes or CI.  ``True``:
    always.  ``False``: never.  A call's own ``progress=`` argument, when not None, wins.
"""

from __future__ import annotations

progress: bool | None = None
