"""Chapter IV of the thesis: cost functions and correlation criteria (costs.py)."""

from sdctrl.updating.costs import comac, logls, mac, quadratic, relative_error

__all__ = ["comac", "logls", "mac", "quadratic", "relative_error"]
