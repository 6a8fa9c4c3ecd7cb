"""Missed-mode scan of the automatic pole selection: a matched filter on the residual.

For a trial pole on a grid of lines (four damping levels, half-power bandwidths of 2, 8,
32 and 128 lines, capped at 5% damping) the cost decrease of adding it with fixed
parameters, ``||(G_p^T G_p)^-1/2 G_p^T r||^2`` with ``G_p`` its basis orthogonalised against
the current one, is compared with the significance threshold of
:class:`~sdctrl.identification._noise.NoiseTest` (noise level from the running median of
the residual; or, when the noise is independent between lines, of its second
differences, so that the residual of modes not fitted yet, smooth over the lines, is
not taken for the noise that hides them: a cluster fitted by one pole showed no
candidate against the direct field).  Local
maxima above the threshold are the candidates, strongest first, one per half-power band;
each is then judged by the significance test of the selection like any pole.

On a uniform frequency grid the trials whose damping is not capped are placed on the
lines with a real part common to their level, ``-2 pi mult df``; their correlations with
the residual and with the current basis are then convolutions, computed exactly by FFT
(:mod:`~sdctrl.identification._trial_correlation`), and only the noise weighting of each
trial's projector takes products with its columns.

The scan is one replaceable piece: :class:`~sdctrl.identification._selection.AutoSelection`
only calls :meth:`ResidualScan.candidates`.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.extrema import relative_maxima
from sdctrl.identification._trial_correlation import TrialCorrelations, uniform_grid
from sdctrl.identification._noise import projector_diagonal
from sdctrl.identification._residues import basis, pole_from_params, stack
from sdctrl.identification._search import ZETA_MIN

__all__ = ["ZETA_CAP", "ResidualScan"]

#: (bandwidth multiplier of the line spacing, grid stride in lines) of the damping levels
LEVELS = ((1.0, 1), (4.0, 2), (16.0, 4), (64.0, 16))
#: largest damping ratio of a trial pole
ZETA_CAP = 0.05


class ResidualScan:
    """Matched-filter scan of the residual of a fit for missed modes (module notes).

    Parameters
    ----------
    prob : PoleProblem
        The pole-search problem (data, Laplace points, parametrisation).
    freq : ndarray, shape (nf,)
        Frequency lines (Hz) of the band.
    noise : NoiseTest
        Noise field and threshold of the significance test.
    chunk : int
        Trial poles evaluated per batch.
    """

    def __init__(self, prob, freq, noise, chunk: int = 256):
        self.prob, self.freq, self.noise, self.chunk = prob, freq, noise, chunk
        self.df = float(np.median(np.diff(freq)))
        self.grid = uniform_grid(freq)
        self._trials = {}                       # trial-pole bases, kept between scans

    def _trial_basis(self, key, lam):
        """Stacked basis of the scan's trial poles ``lam``, kept between scans when the
        whole grid takes at most ``2^23`` numbers: the trial poles do not depend on the
        current model."""
        G = self._trials.get(key)
        if G is None:
            prob = self.prob
            G = stack(basis(lam, prob.s, prob.k, prob.model, (False, False), prob.weight))
            # four damping levels, about 1 + 1/2 + 1/4 + 1/16 trials per line
            if 2 * prob.s.size * 1.9 * self.freq.size * prob.npp <= 2**23:
                self._trials[key] = G
        return G

    def _gain(self, G, r, sig2, Gr=None):
        """Cost decrease ``dJ`` of each trial (columns of ``G``, orthogonalised) and the
        noise variance ``ds`` (T, k) it sees through its projector.

        ``Gr = G^T r`` when already known (FFT correlations; ``r`` is orthogonal to the
        current basis, so the orthogonalised and the plain columns give the same
        products).  ``sig2`` (nf, k) is the noise field per line, the same for the real
        and the imaginary rows (``E[r_re^2 + r_im^2]``, half each, per parameter of the
        pole): the projector diagonal is summed over the two rows of a line first, and
        the three products of ``[g0 g1]`` are combined before the one product with
        ``sig2``.
        """
        if Gr is None:
            Gr = G.T @ r
        nf = self.freq.size
        if self.prob.npp == 2:
            # cost decrease and d^T sig2, d the diagonal of the projector on
            # [g0 g1]: (c g0^2 - 2b g0 g1 + a g1^2) / (ac - b^2)
            g0, g1 = G[:, 0::2], G[:, 1::2]
            g00, g01, g11 = g0 * g0, g0 * g1, g1 * g1
            a = np.sum(g00, axis=0)
            b = np.sum(g01, axis=0)
            c = np.sum(g11, axis=0)
            det = np.maximum(a * c - b * b, 1e-300)
            p0, p1 = Gr[0::2], Gr[1::2]
            num = (c * np.sum(p0 * p0, axis=1) - 2 * b * np.sum(p0 * p1, axis=1)
                   + a * np.sum(p1 * p1, axis=1))
            dJ = num / det
            d = (c * g00 - 2 * b * g01 + a * g11) / det
        else:
            dJ = np.sum(Gr**2, axis=1) / np.maximum(np.sum(G * G, axis=0), 1e-300)
            d = projector_diagonal(G[:, :, None])
        ds = (0.5 / self.prob.npp) * ((d[:nf] + d[nf:]).T @ sig2)
        return dJ, ds

    def _level(self, corr, Q, r, sig2, mult, stride):
        """Significance ratio and damping of the trials of one damping level.

        Trials whose damping is not capped sit on the lines with the real part
        ``-2 pi mult df`` common to the level: on a uniform grid their correlations with
        the residual and the current basis come from ``corr`` (FFT); the others (capped
        damping, or no uniform grid) are formed by products.
        """
        idx = np.arange(4, self.freq.size - 4, stride)    # grid finer than a quarter bandwidth
        level = np.zeros(idx.size)
        zlev = np.zeros(idx.size)
        sigma = 2 * np.pi * mult * self.df
        for i0 in range(0, idx.size, self.chunk):
            ii = idx[i0:i0 + self.chunk]
            fl = self.freq[ii]
            zr = mult * self.df / fl
            zl = np.clip(zr, ZETA_MIN * 10, ZETA_CAP)
            fast = (zr == zl) if corr is not None else np.zeros(ii.size, bool)
            out = np.zeros(ii.size)
            for sel, on_grid in ((fast, True), (~fast, False)):
                if not sel.any():
                    continue
                if on_grid:
                    lam = -sigma + 1j * corr.omega(ii[sel])
                    G = self._trial_basis((mult, i0, True), lam)
                    T, Gr = corr.products(sigma, ii[sel])
                    G = G - Q @ T.T
                else:
                    lam = pole_from_params(2 * np.pi * fl[sel], zl[sel])
                    G = self._trial_basis((mult, i0, False), lam)
                    G = G - Q @ (Q.T @ G)
                    Gr = None
                dJ, ds = self._gain(G, r, sig2, Gr)
                out[sel] = dJ / np.maximum(self.noise.threshold(ds), self.noise.floor)
            level[i0:i0 + ii.size] = out
            zlev[i0:i0 + ii.size] = zl
        return idx, level, zlev

    def candidates(self, ev, tried=(), max_add: int = 6, smooth: bool = False):
        """Missed modes (frequency Hz, damping) in the residual of the fit ``ev``.

        Parameters
        ----------
        ev : dict
            The fit (:meth:`PoleProblem.evaluate`).
        tried : sequence of float
            Frequencies (Hz) already tried and rejected: no candidate within 1.5 lines.
        max_add : int
            Maximum number of candidates.
        smooth : bool
            Compare the trials with the noise field of second differences (module
            notes), else with the direct field.

        Returns
        -------
        list of (float, float)
            ``(frequency Hz, damping ratio)``, strongest first.
        """
        Q, r = ev["lsq"].Q, ev["r"]
        sig2 = self.noise.field(ev, smooth=smooth)
        prob = self.prob
        corr = None if self.grid is None else TrialCorrelations(
            self.grid, prob.s, prob.k, prob.model, (Q, r), prob.weight)
        found = []                                # (ratio, line index, damping)
        for mult, stride in LEVELS:
            idx, level, zlev = self._level(corr, Q, r, sig2, mult, stride)
            pk = relative_maxima(level, order=2)
            found += [(level[i], idx[i], zlev[i]) for i in pk if level[i] > 1.0]
        return self._suppress(found, tried, max_add)

    def _suppress(self, found, tried, max_add):
        """Strongest first; one candidate per half-power band (non-maximum suppression)."""
        found.sort(key=lambda c: -c[0])
        cand = []
        for _, i, zi in found:
            fi = float(self.freq[i])
            excl = [(t, 1.5 * self.df) for t in tried] + \
                   [(c[0], max(2 * c[1] * c[0], 2 * self.df)) for c in cand]
            if any(abs(fi - t) < d for t, d in excl):
                continue
            cand.append((fi, float(zi)))
            if len(cand) >= max_add:
                break
        return cand
