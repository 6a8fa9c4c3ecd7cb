"""Log-magnitude ratio of two responses, the term of the logLS cost (3.12).

Internal module: the function trusts its inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["log_magnitude_ratio"]


def log_magnitude_ratio(a, b) -> np.ndarray:
    """``ln|a| - ln|b|`` entry by entry, each magnitude raised by the smallest positive float
    so that an exact zero stays finite (3.12)."""
    tiny = np.finfo(float).tiny
    return np.log(np.abs(a) + tiny) - np.log(np.abs(b) + tiny)
