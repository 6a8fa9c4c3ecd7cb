"""Shared test configuration: hypothesis profiles.

``ci`` (the default) is derandomised -- the same examples on every run, no example database --
and sized so that the property suites run thousands of examples in well under a minute.
``deep`` draws fresh random examples, twenty times as many, for local hunting:

    SDCTRL_HYPOTHESIS_PROFILE=deep python -m pytest tests/test_file_mutations.py
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", derandomize=True, database=None, deadline=None, max_examples=100, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    "deep", derandomize=False, deadline=None, max_examples=2000, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("SDCTRL_HYPOTHESIS_PROFILE", "ci"))

