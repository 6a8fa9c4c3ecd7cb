"""Correlations of on-grid trial poles with data columns by FFT (residual scan, 3.2.1).

On a uniform grid ``s_l = i (w_0 + l dw)``, a trial pole on a line, ``lambda_i = -sigma +
i (w_0 + i dw)``, has basis functions (3.15) whose inner products with a column
``y = [Re u; Im u]`` are correlations:

``A_i = sum_l conj(1 / (s_l - lambda_i)) u'_l = sum_l u'_l / (sigma + i dw (i - l))``,
``B_i = sum_l conj(1 / (s_l - conj(lambda_i))) u'_l = sum_l u'_l / (sigma - i (2 w_0 +
dw (i + l)))``,

with ``u' = conj(s^k) w u`` (measured quantity, ``w`` the line weight): ``A`` is a convolution in
``i - l``, ``B`` in ``i + l``, both exact and computed for every line at once by FFT, in
``O(nf log nf)`` per column instead of ``O(nf)`` per trial and column.  For the complex-mode pair of
columns ``g1 = (a + b) s^k``, ``g2 = i (a - b) s^k``: ``g1 . y = Re(A + B)``,
``g2 . y = Im(A - B)``; for the real-mode column ``a b s^k = (a - b) s^k / (2 i w_i)``:
``g . y = -Im(A - B) / (2 w_i)``.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TrialCorrelations", "uniform_grid"]


def uniform_grid(freq: np.ndarray, rtol: float = 1e-9):
    """``(w_0, dw)`` in rad/s when the lines are uniform to ``rtol`` of a step, else None.

    Parameters
    ----------
    freq : ndarray, shape (nf,)
        Lines in Hz, increasing.
    rtol : float
        Tolerance on every step, relative to the mean step.

    Returns
    -------
    tuple of float or None
    """
    if freq.size < 8:
        return None
    step = (freq[-1] - freq[0]) / (freq.size - 1)
    if np.max(np.abs(np.diff(freq) - step)) > rtol * step:
        return None
    return 2 * np.pi * float(freq[0]), 2 * np.pi * float(step)


class TrialCorrelations:
    """Inner products of on-grid trial poles' columns with data columns (module notes).

    Parameters
    ----------
    grid : (float, float)
        ``(w_0, dw)`` of the uniform grid (rad/s), :func:`uniform_grid`.
    s : ndarray, shape (nf,)
        Laplace points ``i w_l``.
    k : int
        Power of ``s`` of the measured quantity.
    model : {"complex", "real"}
        Parametrisation (two or one columns per pole).
    columns : sequence of ndarray, shape (2 nf, m_j)
        Real stacked data column sets (e.g. the residual and the current basis ``Q``).
    weight : ndarray, shape (nf,), optional
        Weight of each line of the trial columns (the search's, ``PoleProblem.weight``).
    """

    def __init__(self, grid, s, k, model, columns, weight=None):
        from scipy.fft import fft, next_fast_len

        self.w0, self.dw = grid
        self.nf = nf = s.size
        self.model = model
        self.N = next_fast_len(3 * nf - 2)
        sk = np.conj(s**k) if k else np.ones(nf)
        sk = sk if weight is None else sk * weight
        self.sizes = [c.shape[1] for c in columns]
        U = np.concatenate([c[:nf] + 1j * c[nf:] for c in columns], axis=1) * sk[:, None]
        self.Uf = fft(U, self.N, axis=0)
        self.Vf = fft(U[::-1], self.N, axis=0)
        self._levels = {}

    def omega(self, idx: np.ndarray) -> np.ndarray:
        """Imaginary parts (rad/s) of the trial poles on lines ``idx``.

        Parameters
        ----------
        idx : ndarray of int
            Line indices.

        Returns
        -------
        ndarray
            ``w_0 + idx dw``.
        """
        return self.w0 + self.dw * np.asarray(idx, float)

    def _correlations(self, sigma: float):
        """``A`` and ``B`` (nf, sum m_j) of every line for the real part ``-sigma``."""
        from scipy.fft import fft, ifft

        if sigma not in self._levels:
            nf, N = self.nf, self.N
            m = np.arange(-(nf - 1), nf)
            ka = 1.0 / (sigma + 1j * self.dw * m)               # index i - l + nf - 1
            kb = 1.0 / (sigma - 1j * (2 * self.w0 + self.dw * np.arange(2 * nf - 1)))
            A = ifft(self.Uf * fft(ka, N)[:, None], axis=0)[nf - 1:2 * nf - 1]
            B = ifft(self.Vf * fft(kb, N)[:, None], axis=0)[nf - 1:2 * nf - 1]
            self._levels = {sigma: (A, B)}                      # one level at a time
        return self._levels[sigma]

    def products(self, sigma: float, idx: np.ndarray) -> list[np.ndarray]:
        """``G^T y`` for the trials on lines ``idx`` with real part ``-sigma``, per column set.

        Parameters
        ----------
        sigma : float
            Minus the real part of the trial poles (rad/s).
        idx : ndarray of int
            Lines of the trials.

        Returns
        -------
        list of ndarray, shape (npp T, m_j)
            Rows in the order of the trials' basis columns (``g1, g2`` per trial for the
            complex model).
        """
        A, B = self._correlations(sigma)
        A, B = A[idx], B[idx]
        if self.model == "complex":
            P = np.empty((2 * idx.size, A.shape[1]))
            P[0::2] = (A + B).real
            P[1::2] = (A - B).imag
        else:
            P = -(A - B).imag / (2 * self.omega(idx))[:, None]
        return np.split(P, np.cumsum(self.sizes)[:-1], axis=1)
