"""Files written by sdctrl before the layout change (stop 19 main), kept to check sd.load."""
import numpy as np, warnings
import sdctrl as sd
from sdctrl.io import save_npz
warnings.simplefilter("ignore")
frf = sd.testbed_frf(noise=0.01, seed=0)
small = frf.band(14, 20)
save_npz(small, "frf_save_npz.npz")
sd.save(small, "frf")
cm = sd.identify(small)
sd.save(cm, "complex_modes")
nm = sd.normal_modes(cm)
sd.save(nm, "normal_modes")
fe = sd.testbed(link_stiffness=0.75, plate_mass=1.25)
sd.save(fe, "fe")
links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
plates = fe.mass_parameter("plates",
                           [f"N{k}" for k in (*range(31, 36), *range(38, 43), *range(45, 50))])
res = sd.update(fe, small, [links, plates], damping=nm)
sd.save(res, "update_result")
ide = sd.identifiability(fe, small, [links, plates])
sd.save(ide, "identifiability")
hy = sd.hybrid(res.fe, nm, list(small.sensors))
sd.save(hy, "hybrid")
um = nm.replace(E=None, F=None).uncertain(dGamma=0.2 * abs(nm.Gamma))
sd.save(um, "uncertain")
print(cm, nm, res, ide, hy, um, sep="\n")
import pickle
