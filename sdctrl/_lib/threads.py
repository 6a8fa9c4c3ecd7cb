"""BLAS thread policy of sdctrl's iterative kernels (internal).

Pole searches, Riccati iterations and the other loops of small dense products run on one
BLAS thread: on small matrices OpenBLAS threads only add synchronisation (with 2 shared
cores they made small solves 10-300x slower).  The limit is a threadpoolctl context,
scoped to the call and restored on exit, even on error or Ctrl-C; nothing changes the
process-wide setting outside it.

``identify`` runs entirely in it, its large one-off products too (data compression and
final residues of 1000 sensors x 3 references x 4000 lines): measured on the busy 2-core
machine (load ~7), two BLAS threads took 19 s of wall time for them, one thread 3 s
(CPU 9.3 s vs 1.5 s), so one policy, one thread, for the whole call.

threadpoolctl is a declared dependency (it is what makes that limit scoped); in an
environment that lacks it anyway, the context does nothing: results are the same, only the
small products may run slower on a busy machine.
"""

from __future__ import annotations

import contextlib
import sys

try:
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover - declared dependency; exercised by a test
    ThreadpoolController = None

__all__ = ["single_thread"]

_CONTROLLER: dict = {}


def single_thread():
    """Context limiting BLAS to one thread, restored on exit (even on error).

    The controller (the list of loaded BLAS libraries, ~1 ms to build) is cached and
    rebuilt when modules were imported since, which may have loaded another BLAS (a
    library the cached controller did not know would keep its threads).

    Returns
    -------
    context manager
    """
    if ThreadpoolController is None:
        return contextlib.nullcontext()
    n = len(sys.modules)
    if _CONTROLLER.get("modules") != n:
        _CONTROLLER["controller"] = ThreadpoolController()
        _CONTROLLER["modules"] = n
    return _CONTROLLER["controller"].limit(limits=1, user_api="blas")
