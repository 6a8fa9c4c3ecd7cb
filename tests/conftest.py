"""Shared test configuration: hypothesis profiles.

``ci`` (the default) is derandomised -- the same examples on every run, no example database --
and sized so that the property suites run thousands of examples in well under a minute.
``deep`` draws fresh random examples, twenty times as many, for local hunting:

    SDCTRL_HYPOTHESIS_PROFILE=deep python -m pytest tests/test_file_mutations.py
"""

import contextlib
import os
import signal
import threading
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

import sdctrl as sd
from sdctrl.testbeds._measurement_noise import relative_noise

settings.register_profile(
    "ci", derandomize=True, database=None, deadline=None, max_examples=100, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    "deep", derandomize=False, deadline=None, max_examples=2000, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("SDCTRL_HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session", autouse=True)
def _one_blas_thread_per_xdist_worker():
    """Under pytest-xdist (``-n 2``: one worker per core), each worker's BLAS runs on one
    thread, so that two workers do not each start a BLAS thread per core on a machine whose
    cores they already fill; scoped to the session and restored at its end.  A run without
    xdist keeps the process's own setting."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        yield
        return
    import scipy.linalg  # noqa: F401  (scipy's own BLAS loaded, so that the limit covers it)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


class Hang(Exception):
    """A call outlived its deadline (raised by the ``deadline`` fixture's guard)."""


@contextlib.contextmanager
def _deadline(seconds: float):
    """Interrupt the block with :class:`Hang` after ``seconds`` (POSIX main thread; else no-op).

    A blocking system call (``open`` on a FIFO, a read) is interrupted by the signal too.
    """
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable:
        yield
        return

    def fire(signum, frame):
        raise Hang(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="session")
def deadline():
    """``with deadline(5): call()`` fails the test with :class:`Hang` instead of hanging."""
    return _deadline


# ------------------------------------- an identified 3-DOF chain (statistics plots, issue 24)
def _chain(n=3):
    M = np.diag(np.linspace(1.0, 1.4, n))
    k = 1e4 * np.linspace(1.0, 1.5, n)
    K = np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    return M, K, 2e-4 * K + 0.3 * M


@pytest.fixture(scope="session")
def chain_identified():
    """A 3-DOF chain tested with 2% noise on every mass from mass 1, identified."""
    M, K, C = _chain()
    f = np.linspace(2.0, 40.0, 240)
    s = 2j * np.pi * f
    H0 = np.linalg.inv(M * (s**2)[:, None, None] + C * s[:, None, None] + K)[:, :, :1]
    labels = ("N1.x", "N2.x", "N3.x")
    frf = sd.FRF(f, relative_noise(H0, 0.02, 0), sensors=labels, actuators=labels[:1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return frf, sd.identify(frf, progress=False), (M, K, C, labels)
