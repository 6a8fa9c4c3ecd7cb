"""Update an FE model against a vibration test (thesis chapter IV).

The analyst's FE model of the built-in testbed is wrong: its plate/post links are 25% too
soft and its plates 25% too heavy (``sd.testbed(link_stiffness=0.75, plate_mass=1.25)``).
The test (31 sensors x 6 shakers, 1% noise) has sensor and actuator labels that are DOF
labels of the FE model, which ties the two.

1. six parameters, additive corrections of the FE matrices (4.15), built from the model's
   own element groups and nodes: the stiffness of each post section, the mass of each
   plate, and that of the truss longerons (which are right: the update must leave them);
2. ``sd.identifiability`` says, before any update, whether the test can determine each of
   them and which pairs it cannot tell apart (Table 4.1);
3. ``sd.update`` fits them: MAC-paired frequencies first (4.8), then the logLS cost (3.12)
   on a reanalysed reduced model (4.17) with static correction modes (4.23), the damping
   taken from the identified normal modes;
4. the updated properties are checked against the truth (within 2%) and the FE modes
   against the test.

Usage: ``python update_fe.py [outdir]`` (figures are written to ``outdir`` when given).
"""
import os
import pathlib
import sys

import numpy as np

import sdctrl as sd

quiet = bool(os.environ.get("SDCTRL_QUIET"))
out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else None

# the test and its identified normal modes (see identify_test.py)
frf = sd.testbed_frf(noise=0.01, seed=0)
cm = sd.identify(frf, progress=not quiet)
nm = sd.normal_modes(cm, modes=cm.in_band)             # the structure's modes of the band

# 1. the wrong model and its parameters
fe = sd.testbed(link_stiffness=0.75, plate_mass=1.25)
plates = {"A": range(31, 36), "B": range(38, 43), "C": range(45, 50)}   # centre + corners
params = [fe.stiffness_parameter("post_AB", section="post_AB"),
          fe.stiffness_parameter("post_C", section="post_C"),
          *[fe.mass_parameter(f"plate_{k}", [f"N{i}" for i in nodes])
            for k, nodes in plates.items()],
          fe.stiffness_parameter("longerons", section="longeron")]
truth = {"post_AB": 1 / 0.75 - 1, "post_C": 1 / 0.75 - 1, "plate_A": 1 / 1.25 - 1,
         "plate_B": 1 / 1.25 - 1, "plate_C": 1 / 1.25 - 1, "longerons": 0.0}

# 2. can the test determine them?
ident = sd.identifiability(fe, frf, params)
print(ident.report())
# every parameter determined far below its standard change; plate_A and plate_B estimates
# are correlated beyond 0.95, yet each is determined to about 1e-5: not confounded
assert not ident.weak and all(ident.std[p.name] < 1e-3 for p in params)
assert not ident.confounded

# 3. the update
res = sd.update(fe, frf, params, damping=nm, progress=not quiet)
print(res.report())

# 4. against the truth: the physical property is (1 + p) times the wrong model's factor
factor = {"post_AB": 0.75, "post_C": 0.75, "plate_A": 1.25, "plate_B": 1.25, "plate_C": 1.25,
          "longerons": 1.0}
print(f"{'parameter':>10} {'fitted p':>9} {'true p':>8} {'property / true':>16}")
for name, p in res.values.items():
    prop = (1 + p) * factor[name]
    print(f"{name:>10} {p:9.4f} {truth[name]:8.4f} {prop:16.4f}")
    assert abs(prop - 1) < 0.02, name
f_true, _ = sd.testbed().modes(18)
f_wrong, _ = fe.modes(18)
f_upd, _ = res.fe.modes(18)


def err(f):
    """Largest relative error (%) of the 12 band modes (the first six are suspension)."""
    return 100 * np.abs(f[6:] / f_true[6:] - 1).max()


print(f"FE frequencies in the band: errors up to {err(f_wrong):.1f} % before, "
      f"{err(f_upd):.2f} % after; logLS {res.cost_before:.3g} -> {res.cost_after:.3g}")
assert err(f_upd) < 0.5 and res.cost_after < 0.01 * res.cost_before

if out is not None:
    import matplotlib

    matplotlib.use("Agg")
    from sdctrl.testbeds import SENSORS, SHAKERS

    wrong_model = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 40, static=True)
    sd.plot.bode([frf, wrong_model, res.model], labels=["test", "FE before", "FE updated"],
                 channels=[("N32.z", "N32.z"), ("N41.y", "N41.y")], path=out / "update_bode.png")
    sd.plot.mac(nm, res.model, names=("test", "updated FE"),
                path=out / "update_mac.png")
    print(f"wrote the figures to {out}")
