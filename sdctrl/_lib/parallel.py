"""Sweeps split in chunks, run serially or on any executor (internal).

Every sweep of sdctrl (D-strut placement, FRF envelopes, diagnosis scans) is a list of
independent chunks evaluated by one module-level function ``fn(chunk, shared)``: ``shared``
holds what every chunk reads (the model, the FE model), ``chunk`` the chunk's own part.
:func:`map_chunks` runs it

- serially (``executor=None``): ``fn(chunk, shared)`` in order, in this process;
- on any ``concurrent.futures.Executor`` (threads, processes): ``executor.map``, results in
  chunk order;
- on a Dask client's executor (``client.get_executor()``): ``shared`` is scattered to the
  workers once (``client.scatter(..., broadcast=True)``) and each task carries only its chunk
  and a reference to it, instead of shipping the model with every task.

The chunks do not depend on the executor and each chunk is evaluated by the same function
on the same numbers (one BLAS thread, :func:`~sdctrl._lib.threads.single_thread`), so the
results are identical to the serial run's, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

from sdctrl._lib.progress import progress_bar
from sdctrl._lib.threads import single_thread

__all__ = ["Shared", "chunked", "dask_client", "map_chunks", "share"]


@dataclass(frozen=True, eq=False)
class Shared:
    """What the tasks of one executor read: the value, or a Dask future of it.

    Parameters
    ----------
    handle : object
        The value itself (serial runs, threads, processes) or a Dask future of it.
    """

    handle: object


def chunked(items, size: int) -> list:
    """``items`` cut in consecutive slices of at most ``size`` (the last shorter).

    Parameters
    ----------
    items : sequence
        Anything sliceable.
    size : int
        Slice length, >= 1.

    Returns
    -------
    list
    """
    return [items[i:i + size] for i in range(0, len(items), size)]


def dask_client(executor):
    """The Dask client behind ``client.get_executor()``, else None."""
    client = getattr(executor, "_client", None)
    return client if callable(getattr(client, "scatter", None)) else None


def share(executor, value) -> Shared:
    """``value`` placed once where the executor's tasks read it (for several sweeps).

    Parameters
    ----------
    executor : Executor or None
        The executor that will run the tasks.
    value : object
        What every task reads.

    Returns
    -------
    Shared
        Holding a Dask future of ``value`` scattered to every worker (Dask executors),
        else ``value`` itself (pickled with each task by a process pool).
    """
    client = dask_client(executor)
    if client is None:
        return Shared(value)
    return Shared(client.scatter(value, broadcast=True, hash=False))


def _call(fn, chunk, shared):
    with single_thread():
        return fn(chunk, shared)


def map_chunks(fn, chunks, shared, executor=None, progress=None, desc=None, unit="it") -> list:
    """``[fn(chunk, shared) for chunk in chunks]``, on ``executor`` when given.

    Parameters
    ----------
    fn : callable
        Module-level function ``fn(chunk, shared)`` (picklable).
    chunks : list
        The chunks.
    shared : object or Shared
        What every chunk reads (scattered on Dask, unless already a :class:`Shared`).
    executor : concurrent.futures.Executor, optional
        None runs serially.
    progress : bool or None
        Progress bar over the chunks (``sdctrl.config.progress`` when None).
    desc, unit : str, optional
        Progress bar label and unit.

    Returns
    -------
    list
        One result per chunk, in chunk order.
    """
    n = len(chunks)
    if executor is None:
        value = shared.handle if isinstance(shared, Shared) else shared
        it = (_call(fn, c, value) for c in chunks)
    else:
        handle = (shared if isinstance(shared, Shared) else share(executor, shared)).handle
        it = executor.map(_call, [fn] * n, chunks, [handle] * n)
    return list(progress_bar(it, total=n, desc=desc, unit=unit, enabled=progress))
