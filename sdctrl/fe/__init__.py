"""Finite elements: :class:`FEModel` (model.py, validation.py) with its normal modes
(eigen.py), static correction 2.21 and principal static modes 4.24 (static.py) and
normal-mode models 2.15/2.22 (reduction.py), and a small element library (elements.py:
bar, 3-D Euler-Bernoulli beam) with a vectorised sparse assembler (assembly.py: also
lumped mass/inertia, spring, dashpot) that keeps an :class:`Assembly` record of the
element groups, and design parameters (parameters.py: :class:`Parameter`, 4.15) built from
them (groups.py: ``FEModel.stiffness_parameter``, ``FEModel.mass_parameter``).
"""

from sdctrl.fe._assembly import assemble
from sdctrl.fe._elements import DIRECTIONS, assemble_coo
from sdctrl.fe._eigen import DENSE_MAX, RIGID_RTOL
from sdctrl.fe._elements import bar_matrices, beam_axes, beam_matrices
from sdctrl.fe._groups import Assembly
from sdctrl.fe._fe_model import FEModel
from sdctrl.fe._parameters import Parameter, load_shapes
from sdctrl.fe._static import principal_static_modes

__all__ = [
    "DENSE_MAX",
    "DIRECTIONS",
    "RIGID_RTOL",
    "Assembly",
    "FEModel",
    "Parameter",
    "assemble",
    "assemble_coo",
    "bar_matrices",
    "beam_axes",
    "beam_matrices",
    "load_shapes",
    "principal_static_modes",
]
