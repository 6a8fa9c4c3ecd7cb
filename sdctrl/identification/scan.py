"""Missed-mode scan of the automatic pole selection: a matched filter on the residual.

For a trial pole on a grid of lines (four damping levels, half-power bandwidths of 2, 8,
32 and 128 lines, capped at 5% damping) the cost decrease of adding it with fixed
parameters, ``||(G_p^T G_p)^-1/2 G_p^T r||^2`` with ``G_p`` its basis orthogonalised against
the current one, is compared with the significance threshold of
:class:`~sdctrl.identification.noise.NoiseTest` (noise level from the running median of
the residual).  Local maxima above the threshold are the candidates, strongest first, one
per half-power band.

The scan is one replaceable piece: :class:`~sdctrl.identification.selection.AutoSelection`
only calls :meth:`ResidualScan.candidates`.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification.noise import projector_diagonal
from sdctrl.identification.residues import basis, pole_from_params, stack
from sdctrl.identification.search import ZETA_MIN

__all__ = ["ResidualScan"]

#: (bandwidth multiplier of the line spacing, grid stride in lines) of the damping levels
LEVELS = ((1.0, 1), (4.0, 2), (16.0, 4), (64.0, 16))


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
        self._trials = {}                       # trial-pole bases, kept between scans

    def _trial_basis(self, key, fl, zl):
        """Stacked basis of the scan's trial poles (frequencies ``fl`` Hz, damping ``zl``),
        kept between scans when the whole grid takes at most ``2^23`` numbers: the
        trial poles do not depend on the current model."""
        G = self._trials.get(key)
        if G is None:
            prob = self.prob
            lam = pole_from_params(2 * np.pi * fl, zl)
            G = stack(basis(lam, prob.s, prob.k, prob.model, (False, False)))
            # four damping levels, about 1 + 1/2 + 1/4 + 1/16 trials per line
            if 2 * prob.s.size * 1.9 * self.freq.size * prob.npp <= 2**23:
                self._trials[key] = G
        return G

    def _gain(self, G, r, sig2s):
        """Cost decrease ``dJ`` of each trial (columns of ``G``, orthogonalised) and the
        noise variance ``ds`` (T, k) it sees through its projector."""
        Gr = G.T @ r
        if self.prob.npp == 2:
            # cost decrease and d^T sig2s, d the diagonal of the projector on
            # [g0 g1]: (c g0^2 - 2b g0 g1 + a g1^2) / (ac - b^2), by products
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
            ds = (c[:, None] * (g00.T @ sig2s) - 2 * b[:, None] * (g01.T @ sig2s)
                  + a[:, None] * (g11.T @ sig2s)) / det[:, None]
        else:
            dJ = np.sum(Gr**2, axis=1) / np.maximum(np.sum(G * G, axis=0), 1e-300)
            ds = projector_diagonal(G[:, :, None]).T @ sig2s
        return dJ, ds

    def _level(self, Q, r, sig2s, mult, stride):
        """Significance ratio and damping of the trials of one damping level."""
        idx = np.arange(4, self.freq.size - 4, stride)    # grid finer than a quarter bandwidth
        level = np.zeros(idx.size)
        zlev = np.zeros(idx.size)
        for i0 in range(0, idx.size, self.chunk):
            ii = idx[i0:i0 + self.chunk]
            fl = self.freq[ii]
            zl = np.clip(mult * self.df / fl, ZETA_MIN * 10, 0.05)
            G = self._trial_basis((mult, i0), fl, zl)
            G = G - Q @ (Q.T @ G)
            dJ, ds = self._gain(G, r, sig2s)
            thr = np.maximum(self.noise.threshold(ds), self.noise.floor)
            level[i0:i0 + ii.size] = dJ / thr
            zlev[i0:i0 + ii.size] = zl
        return idx, level, zlev

    def candidates(self, ev, tried=(), max_add: int = 6):
        """Missed modes (frequency Hz, damping) in the residual of the fit ``ev``.

        Parameters
        ----------
        ev : dict
            The fit (:meth:`PoleProblem.evaluate`).
        tried : sequence of float
            Frequencies (Hz) already tried and rejected: no candidate within 1.5 lines.
        max_add : int
            Maximum number of candidates.

        Returns
        -------
        list of (float, float)
            ``(frequency Hz, damping ratio)``, strongest first.
        """
        from scipy.signal import argrelmax

        Q, r = ev["lsq"].Q, ev["r"]
        sig2 = self.noise.field(ev)
        sig2s = 0.5 * np.concatenate([sig2, sig2]) / self.prob.npp       # per real entry
        found = []                                # (ratio, line index, damping)
        for mult, stride in LEVELS:
            idx, level, zlev = self._level(Q, r, sig2s, mult, stride)
            pk = argrelmax(level, order=2)[0]
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
