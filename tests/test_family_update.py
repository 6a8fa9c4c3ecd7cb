"""FE update over the family of test structures (issue 22): the two parameters of each
member's deliberately wrong FE model, noise-free and at 1% noise, locked per member.

The issue's targets: within 0.01 of the truth noise-free, 0.02 at 1%, and the final cost at
the noise floor.  MEASURED (seed 1, 400 lines, default options; parameter error = value -
truth; ratio = final logLS / the data's noise floor, :mod:`sdctrl.updating._fit_floor`):

=========== ===================== ======== ===================== =======
member       noise-free errors     ratio    1% errors             ratio
=========== ===================== ======== ===================== =======
truss        +1.4e-3, +8.4e-4      152      +1.3e-3, +7.9e-4      4.7
truss_high   +1.4e-3, +8.5e-4      1,250    +1.5e-3, +8.8e-4      7.6
ladder       +3.6e-7, -5.6e-7      0.003    +2e-7, +9.4e-6        0.44
plate        +2.4e-6, +3e-7        0.044    +3.9e-6, +1.4e-5      0.70
cluster      +1.0e-4, +2e-6 (a)    35       +8.1e-4, +3.4e-5      1.6
=========== ===================== ======== ===================== =======

(a) the one member whose default basis grows (modes to 225 Hz,
:mod:`sdctrl.updating._basis_growth`).

Since two changes (before: truss -5e-5 / -3e-5 at 490 / 13.8, truss_high -1.2e-4 /
-1.0e-4 at 3,932 / 22.4, ladder +4.5e-4 at 20 / 3.7, plate +7e-5 / +9e-5 at 22 / 1.0,
cluster +2.9e-4 / +4.4e-4 at 7,877 / 1.9):

- the parameters carry the model's Rayleigh damping (``FEModel.stiffness_parameter``:
  ``beta dK``, ``alpha dM``): with ``C`` fixed the ladder's rungs were 4.5e-4 off, exactly
  the damping the stiffer rungs bring (the true ``C`` given: 2.6e-7);
- the logLS is refined on the basis built around the re-solved model while that moves the
  parameters by a tenth of a standard deviation (``updating._final_stages``: the plate
  noise-free 1.3e-4 -> 2.4e-6);
- every member's final cost is lower (the ratios above; the noise-free cluster 7,877 ->
  35), and at 1% every member is at its floor (was: three of five).

The cluster's hub at 1% moved 4.4e-4 -> 8.1e-4, within its standard deviation (5.5e-4):
the default basis's truncation (a basis grown while it moves the parameters takes it to
1.2e-4, measured and not kept: ``_basis_growth``).  The trusses' errors grew (5e-5 ->
1.4e-3, still 7x inside the issue's 0.01).  Their test
data are not their FE model's response but a modal reduction of it (:func:`sdctrl.testbed_frf`,
modes to five times the band top, static corrections with projected damping; logLS 3.5e-4
from the FE model at the true parameters, noise-free, 7x the 1% floor): no parameter value
reproduces them, and where a fit lands depends on the model that fits them -- the full FE
model's own optimum against these data (a direct solve at each step) is -1.7e-3 / -1.1e-3
from the truth, this update's +1.3e-3 / +7.9e-4, the previous one's -5e-5 / -1e-5.  The
update fits the data better now (ratio 13.8 -> 4.7 at 1%) and its standard deviation covers
its error (1.2e-3, the sensors' scatter: ``tests/test_update_std.py``).
"""

import functools
import warnings

import pytest

import sdctrl as sd

#: (largest |error| of the two parameters, final cost / noise floor) per (member, noise)
MEASURED = {
    ("truss", 0.0): (1.39e-3, 152), ("truss", 0.01): (1.33e-3, 4.69),
    ("truss_high", 0.0): (1.42e-3, 1250), ("truss_high", 0.01): (1.47e-3, 7.64),
    ("ladder", 0.0): (5.6e-7, 0.0026), ("ladder", 0.01): (9.4e-6, 0.44),
    ("plate", 0.0): (2.4e-6, 0.044), ("plate", 0.01): (1.4e-5, 0.70),
    ("cluster", 0.0): (1.03e-4, 35.2), ("cluster", 0.01): (8.06e-4, 1.61),
}
ABOVE = {("truss", 0.0), ("truss_high", 0.0), ("cluster", 0.0)}
GROWN = {("cluster", 0.0)}


@functools.cache
def _updated(name, noise):
    st = sd.testbeds.structure(name)
    frf = st.frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return st, sd.update(st.wrong(), frf, st.parameters(), progress=False)


@pytest.mark.parametrize("noise", [0.0, 0.01])
@pytest.mark.parametrize("name", sd.testbeds.family())
def test_update_locked_per_member(name, noise):
    st, r = _updated(name, noise)
    err = max(abs(r.values[k] - v) for k, v in st.truth.items())
    ref_err, ref_ratio = MEASURED[(name, noise)]
    print(f"\n{name} {noise}: error {err:.2g}, ratio {r.fit.ratio:.1f}")
    assert err <= (0.01 if noise == 0 else 0.02)                # the targets
    assert err <= 1.5 * ref_err + 2e-5                          # locked
    assert r.fit.ratio <= 1.5 * ref_ratio + 0.01
    assert r.fit.above == ((name, noise) in ABOVE)
    grown = any(s["stage"].startswith("basis grown") for s in r.stages)
    assert grown == ((name, noise) in GROWN)
    assert r.cost_after < r.cost_before
