"""FE update over the family of test structures (issue 22): the two parameters of each
member's deliberately wrong FE model, noise-free and at 1% noise, locked per member.

The issue's targets: within 0.01 of the truth noise-free, 0.02 at 1%, and the final cost at
the noise floor.  MEASURED (seed 1, 400 lines, default options; parameter error = value -
truth; ratio = final logLS / the data's noise floor, :mod:`sdctrl.updating._fit_floor`):

=========== ===================== ======== ===================== =======
member       noise-free errors     ratio    1% errors             ratio
=========== ===================== ======== ===================== =======
truss        -5e-5, -1e-5          490      -3e-5, 0              13.8
truss_high   -1.2e-4, -4e-5        3,932    -1.0e-4, -3e-5        22.4
ladder       +4.5e-4, -7e-5        20       +4.5e-4, -6e-5        3.7
plate        +5e-5, +7e-5          22       +5e-5, +9e-5          1.0
cluster      +2.9e-4 (a)           7,877    +4.4e-4, +8e-5        1.9
=========== ===================== ======== ===================== =======

(a) +5e-5, +4e-5 at 7,812 on another machine with the same code: 7,800x above its floor the
noise-free cluster's cost is flat enough for the BLAS kernels' round-off to move the end point
by 2.4e-4, still 35x inside the issue's 0.01.

Every parameter is within 5e-4 of the truth.  At 1% three members end at the floor; the two
trusses do not (13.8x, 22.4x), and noise-free none does: a noise-free floor is the
curvature left at the line spacing (1e-7 to 1e-9), so the reduced models' own truncation
shows -- the trusses' test data are themselves a reduction (28 modes and the shakers' static
modes, :func:`sdctrl.testbed_frf`) which the update's basis (modes to 2.5x the band top,
static modes of the shakers and the parameters' loads) does not reproduce to the noise
(the verdict points at the damping: 57% of the excess at the resonances).  The noise-free
cluster is the one member whose default basis grows (modes to 225 Hz,
:mod:`sdctrl.updating._basis_growth`).
"""

import functools
import warnings

import pytest

import sdctrl as sd

#: (largest |error| of the two parameters, final cost / noise floor) per (member, noise)
MEASURED = {
    ("truss", 0.0): (5e-5, 490), ("truss", 0.01): (3e-5, 13.8),
    ("truss_high", 0.0): (1.2e-4, 3932), ("truss_high", 0.01): (1.0e-4, 22.4),
    ("ladder", 0.0): (4.5e-4, 20.3), ("ladder", 0.01): (4.5e-4, 3.7),
    ("plate", 0.0): (7e-5, 22.4), ("plate", 0.01): (9e-5, 1.0),
    ("cluster", 0.0): (2.9e-4, 7877), ("cluster", 0.01): (4.4e-4, 1.9),
}
AT_FLOOR = {("ladder", 0.01), ("plate", 0.01), ("cluster", 0.01)}
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
    assert r.fit.ratio <= 1.5 * ref_ratio
    assert r.fit.above == ((name, noise) not in AT_FLOOR)
    grown = any(s["stage"].startswith("basis grown") for s in r.stages)
    assert grown == ((name, noise) in GROWN)
    assert r.cost_after < r.cost_before
