"""Measured data: the :class:`FRF` container and where FRFs come from.

Workflow: time records -> :func:`estimate_frf` (H1 with coherence) -> :class:`FRF`, hammer
hits -> :func:`impact_frf` (H1/H2/Hv, force and exponential windows) -> :class:`FRF`, or a file
-> :func:`read_uff` (Universal File Format dataset 58, through pyuff); an FRF is written back
with :func:`write_uff` or saved exactly with :func:`sdctrl.save`.  ``FRF.band``, ``FRF.to``
select a band and convert between displacement, velocity and acceleration.

- ``_frf``: the container, quantity conversion, H1 estimation;
- ``_impact``: impact tests (hammer hits, windows, double hits, overloads);
- ``_uff``: UFF dataset 58 files;
- ``_coherence``: whether a coherence measures the noise (one rule for every step).

Readers refuse, with a ``ValueError`` naming the file and the fault, anything that is not a
complete, consistent file -- a FIFO or a device is refused before it is opened, so no reader
blocks -- and raise an ``OSError`` naming the path when it cannot be opened.  Writers replace
their target atomically.
"""

from sdctrl.data._frf import FRF, estimate_frf
from sdctrl.data._impact import ImpactWarning, impact_frf
from sdctrl.data._uff import read_uff, write_uff

__all__ = ["FRF", "ImpactWarning", "estimate_frf", "impact_frf", "read_uff", "write_uff"]
