"""FRF file I/O: Universal File Format dataset 58 (:mod:`sdctrl.io.uff`, through pyuff) and
numpy ``.npz`` (:mod:`sdctrl.io.npz`).

Readers refuse, with a ``ValueError`` naming the file and the fault, anything that is not a
complete, consistent file -- a FIFO or a device is refused before it is opened, so no reader
blocks -- and raise an ``OSError`` naming the path when it cannot be opened.  Writers replace
their target atomically.
"""

from sdctrl.io.npz import load_npz, save_npz
from sdctrl.io.uff import read_uff, write_uff

__all__ = ["load_npz", "read_uff", "save_npz", "write_uff"]
