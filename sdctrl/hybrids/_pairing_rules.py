"""Which identified modes a hybrid model keeps as measured modes, and what its appended FE
modes inherit from them (5.1.1): out-of-band poles that pair poorly with the FE are absorbed
into the residual terms, poor pairings of the kept ones are warned about, and the appended
modes the test did not measure take the kept in-band modes' mean damping ratio (those it
measured as residual dynamics take their own, :mod:`sdctrl.hybrids._measured_residual`)."""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["absorbed", "in_band_modes", "mean_damping", "warn_poor"]


def warn_poor(km, mac_pairs, mac_min, fe_idx, f_id, f_fe) -> np.ndarray:
    """Kept test modes ``km`` poorly paired (MAC below ``mac_min``), warned about."""
    poor = np.flatnonzero(mac_pairs[km] < mac_min)
    if poor.size:
        desc = ", ".join(f"test mode {km[j]} ({f_id[km[j]]:.2f} Hz) ~ FE mode "
                         f"{fe_idx[km[j]]} ({f_fe[fe_idx[km[j]]]:.2f} Hz), MAC "
                         f"{mac_pairs[km[j]]:.2f}" for j in poor)
        warnings.warn(f"hybrid: poor FE/test mode pairing (MAC < {mac_min:g}): {desc}",
                      stacklevel=3)
    return poor


def absorbed(nm, mac_pairs, mac_min) -> np.ndarray:
    """Out-of-band identified poles that pair poorly: absorbed into the residual terms."""
    ib = in_band_modes(nm)
    if ib is None:
        return np.zeros(nm.n, bool)
    return ~np.asarray(ib, bool) & (mac_pairs < mac_min)


def in_band_modes(nm):
    """Per mode of ``nm``, in the identified band (``nm.properness.in_band``), or None."""
    ib = None if nm.properness is None else nm.properness.in_band
    return None if ib is None or np.shape(ib) != (nm.n,) else np.asarray(ib, bool)


def mean_damping(nm, w_id, kept) -> float:
    """Mean damping ratio of the kept in-band measured modes, given to the appended FE
    modes the test did not measure (5.1.1)."""
    use = kept.copy()
    ib = in_band_modes(nm)
    if ib is not None and np.any(use & ib):
        use &= np.asarray(ib, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.diag(nm.Gamma) / (2 * w_id)
    zeta = zeta[use & (w_id > 0)]
    return float(np.mean(zeta)) if zeta.size else 0.0
