"""The structured singular value (mixed real/complex mu) used by :func:`sdctrl.robust_stability`.

- ``_structure``: block structures and D-G scalings;
- ``_upper``: upper bounds of one matrix (Osborne balancing, BFGS on the D-G scalings);
- ``_lmi``: the D-G LMI solved by cvxpy, the reference and an optional polish;
- ``_lower``: lower bounds (a destabilising real perturbation found by power iteration);
- ``_frequency_sweep``: the upper bound certified over the whole frequency axis.
"""

from sdctrl.robust.mu._lmi import lmi_bound
from sdctrl.robust.mu._structure import BlockStructure
from sdctrl.robust.mu._upper import dg_upper, mu_upper

__all__ = ["BlockStructure", "dg_upper", "lmi_bound", "mu_upper"]
