"""Small markdown reports (the `sdctrl demo` job and model summaries)."""

from __future__ import annotations

import numpy as np

from sdctrl._util import markdown_table

__all__ = ["markdown_table", "modes_table"]


def modes_table(poles, reference=None) -> str:
    """Table of frequencies (Hz) and damping ratios (%) of complex poles (rad/s).

    Parameters
    ----------
    poles : array_like
        Complex poles, upper half-plane.
    reference : array_like, optional
        Reference poles to compare with (same order): errors are added as columns.

    Returns
    -------
    str
        Markdown table.
    """
    poles = np.asarray(poles, dtype=complex)
    f = np.abs(poles) / (2 * np.pi)
    z = -poles.real / np.abs(poles)
    if reference is None:
        rows = [(j + 1, f"{f[j]:.4f}", f"{100 * z[j]:.3f}") for j in range(poles.size)]
        return markdown_table(["mode", "frequency (Hz)", "damping (%)"], rows)
    ref = np.asarray(reference, dtype=complex)
    fr = np.abs(ref) / (2 * np.pi)
    zr = -ref.real / np.abs(ref)
    rows = [(j + 1, f"{fr[j]:.4f}", f"{f[j]:.4f}", f"{(f[j] - fr[j]) / fr[j]:.1e}",
             f"{100 * zr[j]:.3f}", f"{100 * z[j]:.3f}", f"{z[j] - zr[j]:.1e}")
            for j in range(poles.size)]
    return markdown_table(["mode", "f true (Hz)", "f model (Hz)", "rel. error", "zeta true (%)",
                           "zeta model (%)", "abs. error"], rows)
