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
"""

from __future__ import annotations

import sys

from threadpoolctl import ThreadpoolController

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
    n = len(sys.modules)
    if _CONTROLLER.get("modules") != n:
        _CONTROLLER["controller"] = ThreadpoolController()
        _CONTROLLER["modules"] = n
    return _CONTROLLER["controller"].limit(limits=1, user_api="blas")
