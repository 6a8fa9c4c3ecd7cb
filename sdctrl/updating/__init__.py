"""Chapter IV of the thesis: cost functions and correlation criteria (costs.py), expansion
(4.7) and FE/test mode pairing (expansion.py), reanalysis (4.17) (reanalysis.py)."""

from sdctrl.updating.costs import comac, logls, mac, quadratic, relative_error

__all__ = ["comac", "logls", "mac", "quadratic", "relative_error"]
