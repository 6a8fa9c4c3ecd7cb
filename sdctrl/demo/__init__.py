"""The whole story of sdctrl on its built-in testbed, and reports on a user's own data.

``sdctrl demo`` runs :func:`demo`: simulated test -> identification -> normal modes ->
update of a deliberately wrong FE model -> hybrid model -> D-strut placement -> robust
stability under uncertain damping -> diagnosis of an undeclared effect in a second test.
Each step is a small function returning a record (frozen dataclass) with a one-line
``summary``, ``checks()`` (key numbers against the truth), ``numbers()`` (for
``summary.json``) and ``section(doc)`` (its part of the HTML report):

- :mod:`sdctrl.demo._simulated` -- the simulated test and its truth;
- :mod:`sdctrl.demo._test_side` -- identification, normal modes;
- :mod:`sdctrl.demo._modelling` -- FE update, hybrid model, D-strut placement;
- :mod:`sdctrl.demo._robustness` -- structured uncertainty and the robust margin;
- :mod:`sdctrl.demo._diagnosing` -- the second test and its diagnosis;
- :mod:`sdctrl.demo._runner` -- one terminal line per step, failures kept, outputs written;
- :mod:`sdctrl.demo._commands` -- :func:`demo` and :func:`identify_report` (``sdctrl
  identify``).
"""

from sdctrl.demo._commands import demo, identify_report

__all__ = ["demo", "identify_report"]
