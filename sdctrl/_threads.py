"""BLAS thread policy of sdctrl's iterative kernels (internal).

Pole searches, Riccati iterations and the other loops of small dense products run on one
BLAS thread: on small matrices OpenBLAS threads only add synchronisation (with 2 shared
cores they made small solves 10-300x slower).  The limit is a threadpoolctl context,
scoped to the call and restored on exit, even on error or Ctrl-C; nothing changes the
process-wide setting outside it.  Large one-off products (data compression, final
residues on all channels) run outside it, on the caller's setting.
"""

from __future__ import annotations

from threadpoolctl import ThreadpoolController

__all__ = ["single_thread"]

_CONTROLLER: list = []


def single_thread():
    """Context limiting BLAS to one thread, restored on exit (even on error).

    The controller is created once and cached (~20 us per context instead of ~1 ms).

    Returns
    -------
    context manager
    """
    if not _CONTROLLER:
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=1, user_api="blas")
