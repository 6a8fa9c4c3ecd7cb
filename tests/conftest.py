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

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", derandomize=True, database=None, deadline=None, max_examples=100, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    "deep", derandomize=False, deadline=None, max_examples=2000, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("SDCTRL_HYPOTHESIS_PROFILE", "ci"))



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
