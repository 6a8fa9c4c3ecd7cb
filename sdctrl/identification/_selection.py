"""Automatic pole selection of :func:`~sdctrl.identify` when no poles are given (3.2.1).

Starting from the initial candidates (:mod:`~sdctrl.identification._initial`: stable LSCF
poles and peaks of the indicator functions), :class:`AutoSelection` iterates: add a pole
where the residual shows a missed mode (:mod:`~sdctrl.identification._missed_scan`), search
alone the in-band poles a fit pushed to their bounds and a rejected batch's strongest
candidate (:mod:`._travel`), drop poles that do not converge (pushed to a bound), fit noise
(half-power bandwidth below a fraction of the line spacing and a damping the data do not
determine, 3.56), are in-band fillers (large damping, resonance not inside the band) or are
not statistically significant (:mod:`~sdctrl.identification._noise`), and add out-of-band
poles below and above the band (held outside by bounds, within a factor 4 of its edges) that
absorb modes the asymptotic terms ``E``, ``F/s^2`` cannot represent: one per side and pass
while they are significant, so that the fit reaches the noise whatever lies outside the band
(six suspension and plate modes below a band, modes just outside both edges).  Out-of-band
poles are judged against the noise field that excludes residuals smooth in frequency (second
differences, :func:`~sdctrl.identification._noise.noise_field`), in-band poles too when the
data show independent noise; windowed data's poles meet second differences over their gain
for the window (the residual scan, the direct field); at the end, one passive out-of-band
term per side may be placed (:mod:`._far_terms`).  A residual-scan candidate that was
rejected is excluded (1.5 lines around it) only until the model changes: a close mode hidden
while its neighbour was not fitted is proposed again.  Both sides are tried before the first
removal of insignificant poles: the tail of a mode just outside the band inflates the
residual the significance test takes for noise (a lightly damped testbed mode looked 0.3-0.8
times the threshold, then 280 times once the mode above the band was fitted).  A side is
tried again whenever the pole set has changed since its last failed trial (a first fit
missing in-band modes pulls it to a bound).

Initial candidates far below the noise threshold (noise peaks of the indicator functions)
are dropped before the first fit, and isolated insignificant poles are removed together,
so the add/remove loop (at most 20 rounds) stays short.

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

import numpy as np

from sdctrl.identification._far_terms import far_terms, oob_grid
from sdctrl.identification._noise import NoiseTest
from sdctrl.identification._missed_scan import ResidualScan
from sdctrl.identification._rules import INDEPENDENT, SelectionRules, stop_message
from sdctrl.identification._search import OUT_FACTOR, search_poles
from sdctrl.identification._travel import filler, scanned, travel
from sdctrl.identification._zoom import sole_poles, zoom_candidates

__all__ = ["PROBE_EVALS", "RESOLVED_STD", "AutoSelection"]

#: evaluations (varpro; iterations / 10 for the gradient optimiser) of a probe of new poles
PROBE_EVALS = 40
#: largest standard deviation of ``ln zeta`` of a resolved pole narrower than the line
#: spacing: its damping is then more than two standard deviations above zero
RESOLVED_STD = 0.5
#: most poles added on each side of the band
MAX_OUT = 6


class AutoSelection:
    """Add/remove loop of :func:`~sdctrl.identify` when no poles are given (module notes).

    Parameters
    ----------
    prob : PoleProblem
        The pole-search problem.
    freq : ndarray, shape (nf,)
        Frequency lines of the band (Hz).
    fband : (float, float)
        Band in Hz.
    optimizer, max_iter, tol
        Pole search options (:func:`~sdctrl.identification._search.search_poles`).
    min_bandwidth, zeta_max, significance
        Rejection rules (see :func:`~sdctrl.identify`).
    warn : callable
        ``warn(message)`` reports trouble.
    shape : ndarray, shape (nf, k), optional
        Noise shape from the coherence (3.59).
    rules : SelectionRules, optional
        The rules chosen from the data (:func:`~sdctrl.identification._rules.
        selection_rules`: an FRF measured through an exponential window has noise
        correlated between lines and keeps the rules that hold there); default: those of
        noise independent between lines.
    collocated : CollocatedResidues, optional
        The data at the collocated pairs (:mod:`._far_terms`: a term must be passive).
    """

    def __init__(self, prob, freq, fband, optimizer, max_iter, tol, min_bandwidth, zeta_max,
                 significance, warn, shape=None, rules: SelectionRules | None = None,
                 collocated=None):
        self.prob, self.freq, self.fband, self.collocated = prob, freq, fband, collocated
        self.optimizer, self.max_iter, self.tol = optimizer, max_iter, tol
        self.df = float(np.median(np.diff(freq)))
        self.min_bw, self.zeta_max = min_bandwidth, zeta_max
        self.noise = NoiseTest(prob, significance, shape)
        self.rules = INDEPENDENT if rules is None else rules
        self.noise.floor = self.rules.floor * prob.normY2
        self.noise.lower_when_independent = self.rules.smooth_scan
        self.noise.significance_gain = self.rules.significance_gain
        self.scan = ResidualScan(prob, freq, self.noise)
        self.log, self.warn, self.tried, self.best = [], warn, [], None
        self.out_added = {-1: 0, 1: 0}         # out-of-band poles added per side
        self.zoomed, self.travelled, self.alone, self.scanned_from = set(), set(), set(), set()

    def fit(self, w, z, side, only=None):
        """Pole search from ``(w, z)``.

        Parameters
        ----------
        w, z : ndarray
            Initial natural frequencies (rad/s) and damping ratios.
        side : ndarray of int
            0 in band, -1 below, +1 above.
        only : array_like of int, optional
            Poles searched (the others fixed): a probe of new poles, stopped after
            :data:`PROBE_EVALS` evaluations (noise candidates wander towards a bound and
            would use the whole budget; they are rejected all the same).

        Returns
        -------
        tuple
            ``(w, z, ev, info)``: the poles, their evaluation and the search info.
        """
        max_iter = self.max_iter
        if only is not None:        # a probe: true modes converge in ~10 evaluations,
            max_iter = min(max_iter, PROBE_EVALS * (1 if self.optimizer == "varpro" else 10))
        w, z, info = search_poles(self.prob, w, z, side, self.fband, self.optimizer,
                                  max_iter, self.tol, only)
        if only is None and not info.get("converged", True):
            self.log.append(("not converged", info.get("message", "")))
        x = np.concatenate([np.log(w), np.log(z)])
        ev = self.prob.evaluate(x)
        return w, z, ev, info

    def significance(self, w, z, ev, side=None):
        """Cost increase of removing each pole over its noise threshold (>1 keeps).

        Parameters
        ----------
        w, z : ndarray
            Poles of the fit.
        ev : dict
            Their evaluation.
        side : ndarray of int, optional
            0 in band, -1 below, +1 above: out-of-band poles meet the noise field that
            excludes residuals smooth in frequency (:func:`~sdctrl.identification._noise.
            noise_field`, ``smooth=True``).

        Returns
        -------
        ndarray
        """
        return self.noise.significance(w.size, ev, side if self.rules.oob_search else None)

    def missed(self, w, z, ev, max_add=6):
        """Missed modes (frequency Hz, damping) in the residual, strongest first.

        Parameters
        ----------
        w, z : ndarray
            Poles of the fit.
        ev : dict
            Their evaluation.
        max_add : int
            Maximum number of candidates.

        Returns
        -------
        list of (float, float)
        """
        return self.scan.candidates(ev, self.tried, max_add)

    def prune(self, w, z, side, ev, info, weak: bool = True):
        """Poles without the rejected or the insignificant ones, or None if all stay.

        Parameters
        ----------
        w, z : ndarray
            Poles of the fit.
        side : ndarray of int
            0 in band, -1 below, +1 above.
        ev : dict
            Their evaluation.
        info : dict
            The search info (``"at_bound"``).
        weak : bool
            Also remove insignificant poles (else only the rejected ones).

        Returns
        -------
        tuple or None
            ``(w, z, side)`` of the poles kept.
        """
        f = w / (2 * np.pi)
        reasons = self._rejected(w, z, side, info, ev)
        if not reasons and weak:
            sig = self.significance(w, z, ev, side)   # held: the last pole of a window
            held = sole_poles(self.freq, self.prob.Y, self.noise.field(ev), f, z, side == 0,
                              (sig < 1.0) & self.rules.close_modes)   # with modes (_zoom)
            weak = np.flatnonzero((sig < 1.0) & ~held)
            if weak.size:
                # the weakest, and with it every clearly insignificant pole with no other
                # pole nearby (two poles sharing one mode each look insignificant)
                isolated = [j for j in weak if sig[j] < 0.5 and not np.any(
                    (np.arange(w.size) != j)
                    & (np.abs(f - f[j]) < max(10 * self.df, 10 * z[j] * f[j])))]
                for j in {int(weak[np.argmin(sig[weak])]), *isolated}:
                    reasons[j] = f"not significant (cost change {sig[j]:.3g} x noise threshold)"
        if not reasons:
            return None
        drop = np.array(sorted(reasons))
        for j in drop:
            self.log.append(("removed", float(f[j]), float(z[j]), reasons[j]))
            self.tried.append(float(f[j]))
        keep = np.ones(w.size, bool)
        keep[drop] = False
        return w[keep], z[keep], side[keep]

    def _accept(self, w, z, ev, info, new, side):
        """Indices in ``new`` of poles that converged, are not rejected and are significant."""
        bad = self._rejected(w, z, side, info, ev)
        sig = self.significance(w, z, ev, side)
        ok = [j for j in new if sig[j] >= 1.0 and j not in bad]
        return np.array(ok, int)

    def _rejected(self, w, z, side, info, ev):
        """{index: reason} of poles at a bound, fitting noise or filling in.

        An out-of-band pole is judged by its significance alone unless it is pushed
        to a frequency bound: at a damping bound it still carries the tail of a mode
        beyond the band, which no line resolves.
        """
        f = w / (2 * np.pi)
        reasons = {}
        edge = (side == 0) & ((f - self.fband[0] < 0.5 * self.df) |
                              (self.fband[1] - f < 0.5 * self.df))
        at_bound = info.get("at_bound", np.zeros(w.size, bool)) & \
            ((side == 0) | (not self.rules.oob_search))
        # out of band: at the edge it stands for an in-band mode, at the far bound (a
        # factor OUT_FACTOR from the edge) for what the asymptotic terms E, F/s^2 carry
        lo, hi = self.fband[0] * (1 - 1e-6), self.fband[1] * (1 + 1e-6)
        at_edge = ((side < 0) & ((f > lo) | (f < lo / OUT_FACTOR * (1 + 2e-6)))) | \
                  ((side > 0) & ((f < hi) | (f > hi * OUT_FACTOR * (1 - 2e-6))))
        at_edge &= self.rules.oob_search
        for j in np.flatnonzero(at_bound | edge | at_edge):
            reasons[j] = "did not converge (pushed to a bound)"
        for j in self._unresolved(w, z, side, ev, reasons):
            reasons[j] = (f"noise fitting (half-power bandwidth below {self.min_bw:g} line "
                          "spacing, damping not determined by the data)")
        for j in np.flatnonzero((side == 0) & (z > self.zeta_max)):
            if filler(f[j], z[j], self.fband, self.zeta_max):
                reasons.setdefault(j, f"filler (damping above {self.zeta_max:g}, its "
                                   "resonance not inside the band)")
        return reasons

    def _unresolved(self, w, z, side, ev, reasons):
        """Poles whose half-power bandwidth ``2 zeta f`` is below ``min_bandwidth`` line
        spacings and whose damping the data do not determine (noise fitting).

        A pole fitted to the noise of a line or two has a damping the data cannot tell
        from zero; a lightly damped mode under-resolved by the lines but well above the
        noise has its damping set by the lines on its flanks.  In band, a narrow pole is
        kept when its damping is significantly above zero, ``std(ln zeta)`` (3.56) below
        :data:`RESOLVED_STD`.  Out of band no line resolves a peak whatever its
        damping: the rule does not apply there (significance alone judges), except for
        data without the out-of-band search (``rules.oob_search`` False: windowed data),
        where a narrow out-of-band pole is noise fitting.
        """
        f = w / (2 * np.pi)
        narrow = [j for j in np.flatnonzero(2 * z * f < self.min_bw * self.df)
                  if j not in reasons]
        check = [j for j in narrow if side[j] == 0]
        out = [j for j in narrow if side[j] != 0 and not self.rules.oob_search]
        if not check:
            return out
        std = self.noise.log_damping_std(w, z, ev, check)
        return out + [j for j, sj in zip(check, std) if not sj < RESOLVED_STD]

    def _drop_weak_candidates(self, w, z, side, pending):
        """Initial candidates far below the noise threshold at their picked position
        (noise peaks of the indicator functions) are dropped before the first, costly,
        fit; a true mode dropped here is not excluded from the residual scan."""
        if w.size <= 1:
            return w, z, side, pending
        x = np.concatenate([np.log(w), np.log(z)])
        sig0 = self.significance(w, z, self.prob.evaluate(x))
        keep = (sig0 >= 0.2) | (side != 0)
        for j in np.flatnonzero(~keep):
            self.log.append(("dropped candidate", float(w[j] / (2 * np.pi)), float(z[j]),
                             f"cost change {sig0[j]:.3g} x noise threshold"))
        return w[keep], z[keep], side[keep], pending[keep]

    def _out_of_band(self, state, tried_side):
        """Poles just outside the band (the tails of modes there distort the in-band
        residual): one new pole per side and pass, passes repeated while a side keeps
        significant poles.  At most :data:`MAX_OUT` are added per side over the whole
        selection, so that poles a later fit pushes to a far bound (then removed) are not
        tried again and again.  Alternating matters: a mode just outside one edge
        dominates the residual, and poles fitted to it from the other side pile up at
        their far bound.  A side is retried whenever the numbers of in-band poles or of
        poles have changed since its last failed trial.  Returns the new state, or None
        when no pole was added."""
        changed = None
        while True:
            added = False
            for sd in (-1, 1):
                w, z, side = state[:3]
                key = (int(np.count_nonzero(side == 0)), w.size)
                if not self.rules.oob_search:  # one per side, retried when the pole set
                    if tried_side[sd] == key or np.any(side == sd):    # changed (either side)
                        continue
                    tried_side[sd] = key
                elif tried_side[sd] == key or self.out_added[sd] >= MAX_OUT:
                    continue
                new = self._try_side(state, sd)
                if new is None:
                    tried_side[sd] = key
                    continue
                state = changed = self.best = new
                self.out_added[sd] += 1
                added = True
            if not added or not self.rules.oob_search:
                return changed

    def _oob_start(self, state, sd):
        """Starting frequency (Hz) of a new pole on side ``sd``: the best of a geometric
        grid between just outside the band edge and the far bound of the search (the
        edge divided or multiplied by :data:`~sdctrl.identification._search.OUT_FACTOR`)
        by the cost of the fit with the trial pole added (the others fixed); from the
        edge alone, a probe for modes well beyond it ends at the far bound."""
        w, z, side = state[:3]
        grid = oob_grid(self.fband, sd)
        best, fbest = np.inf, grid[0]
        for f0 in grid:
            x = np.concatenate([np.log(np.append(w, 2 * np.pi * f0)),
                                np.log(np.append(z, 0.01))])
            cost = self.prob.evaluate(x)["cost"]
            if cost < best:
                best, fbest = cost, f0
        return fbest

    def _try_side(self, state, sd):
        """One new pole on side ``sd``: probe, then full fit; the new state if it is kept
        (converged away from the band edge and significant), else None."""
        w, z, side = state[:3]
        if self.rules.oob_search:
            f0 = self._oob_start(state, sd)
        else:
            f0 = self.fband[0] * 0.97 if sd < 0 else self.fband[1] * 1.03
        wn = np.concatenate([w, [2 * np.pi * f0]])
        zn = np.concatenate([z, [0.01]])
        sn = np.concatenate([side, [sd]])
        new = np.array([wn.size - 1])
        w2, z2, ev2, info2 = self.fit(wn, zn, sn, only=new)
        if not self._accept(w2, z2, ev2, info2, new, sn).size:
            return None
        w2, z2, ev2, info2 = self.fit(w2, z2, sn)
        if not self._accept(w2, z2, ev2, info2, new, sn).size:
            return None
        if self.rules.retry_rejected:
            self.tried = []                   # the model changed (see _add_missed)
        self.log.append(("added", float(w2[-1] / (2 * np.pi)), float(z2[-1]),
                         "out-of-band mode " + ("below" if sd < 0 else "above")))
        return w2, z2, sn, ev2, info2

    def _add_missed(self, state, cand, reason="residual peak", free=()):
        """Fit the candidates of the residual scan (or pending initial candidates); the
        new state, or None when none of them is kept (the rejected ones are in
        ``self.tried``).  ``free``: indices of fitted poles searched with the new ones
        in the first probe (the poles among which close modes were found)."""
        w, z, side = state[:3]
        n0 = w.size
        wn = np.concatenate([w, [2 * np.pi * c[0] for c in cand]])
        zn = np.concatenate([z, [c[1] for c in cand]])
        sn = np.concatenate([side, np.zeros(len(cand), int)])
        # first the new poles alone (the others fixed), then all of them
        only = np.concatenate([np.asarray(free, int), np.arange(n0, wn.size)])
        w2, z2, ev2, info2 = self.fit(wn, zn, sn, only=only)
        ok = self._accept(w2, z2, ev2, info2, np.arange(n0, w2.size), sn)
        rejected = [float(c[0]) for j, c in enumerate(cand) if n0 + j not in set(ok)]
        if not self.rules.retry_rejected:     # every candidate tried once, never again
            self.tried += [float(c[0]) for c in cand]
        elif ok.size:
            # the model changed: what was rejected (or pruned) before is retried, so that a
            # mode closer than the exclusion (1.5 lines) to one found before is still found
            self.tried = rejected
        else:
            self.tried += rejected
        if not ok.size:
            return None
        keep = np.concatenate([np.arange(n0), ok])
        w2, z2, ev2, info2 = self.fit(w2[keep], z2[keep], sn[keep])
        for j in range(n0, keep.size):
            self.log.append(("added", float(w2[j] / (2 * np.pi)), float(z2[j]), reason))
        return w2, z2, sn[keep], ev2, info2

    def _close_modes(self, state):
        """Close modes a fitted pole hides (:mod:`~sdctrl.identification._zoom`: the
        local rank of the data (3.20)-(3.22) above the poles fitted there, then a zoomed
        LSCF) around the in-band poles and the frequencies rejected before, fitted and
        judged like residual peaks; None when there are none (or the rules exclude it:
        the line-correlated noise of windowed data raises the local rank)."""
        w, z, side, ev = state[:4]
        ib = side == 0
        key = tuple(np.round(np.sort(w[ib]) / (2 * np.pi) / self.df, 1))
        if not self.rules.close_modes or key in self.zoomed:
            return None                       # once per set of in-band poles
        self.zoomed.add(key)
        cand, spans = zoom_candidates(self.freq, self.prob.Y, self.noise.field(ev),
                                      w[ib] / (2 * np.pi), z[ib], self.zeta_max, self.tried)
        f = w / (2 * np.pi)
        free = [j for j in np.flatnonzero(ib) if any(lo <= f[j] <= hi for lo, hi in spans)]
        return self._add_missed(state, cand, "close mode (local rank)", free) if cand else None

    def run(self, w, z, side, bar=None, rounds=20, pending=None):
        """The add/remove loop from initial poles ``(w rad/s, z, side)``.

        Parameters
        ----------
        w, z : ndarray
            Initial natural frequencies (rad/s) and damping ratios.
        side : ndarray of int
            0 in band, -1 below, +1 above.
        bar : progress bar, optional
            Shows the number of poles and the relative cost.
        rounds : int
            Maximum number of rounds.
        pending : ndarray of bool, optional
            Candidates added after the first fit, fitted alone first (peaks no LSCF pole
            explains: a noise peak would wander in the first full search).

        Returns
        -------
        tuple
            ``(w, z, side, ev, info)`` of the last fit (also kept in :attr:`best`).
        """
        pending = np.zeros(w.size, bool) if pending is None else np.asarray(pending, bool)
        w, z, side, pending = self._drop_weak_candidates(w, z, side, pending)
        if pending.all():
            pending[:] = False
        state = self.best = self._first_fit(w[~pending], z[~pending], side[~pending])
        if pending.any():
            new = self._add_missed(state, list(zip(w[pending] / (2 * np.pi), z[pending])),
                                   "peak of the indicator functions")
            state = self.best = state if new is None else new
        tried_side = {-1: None, 1: None}     # (in-band poles, poles) at the last failed trial
        for _ in range(rounds):
            w, z, side, ev, info = state
            if bar is not None:
                bar.set_postfix_str(f"poles={w.size}, cost={ev['cost'] / self.prob.normY2:.2e}")
            # the significance test judges poles against the residual as noise: the tails
            # of modes just outside the band (no candidates there when the FRF has no
            # lines outside it) inflate the residual over the whole band, so insignificant
            # poles are removed only once both sides were tried
            exact = ev["cost"] <= self.noise.floor
            moved = None if exact else travel(self, state)    # pushed to a bound: alone
            if moved is not None:
                state = self.best = moved
                continue
            pr = self.prune(w, z, side, ev, info,
                            weak=exact or self._sides_tried(side, tried_side))
            if pr is not None:
                state = self.best = self._first_fit(*pr)
                continue
            if exact:
                break                         # numerically exact: nothing left to find
            first = not self._sides_tried(side, tried_side)
            new = self._out_of_band(state, tried_side)
            if new is not None or first:      # first trials: then the insignificant poles
                state = state if new is None else new
                continue
            # missed in-band modes: add at residual peaks, keep the significant ones;
            # a round whose candidates were all rejected ends the search
            cand = self.missed(w, z, ev)
            new = scanned(self, state, cand)
            if new is None:
                break
            state = self.best = new
        else:
            self.warn(stop_message(rounds, self.rules))
        return self._final_prune()

    def _final_prune(self):
        """The best state without poles pushed to a bound (an out-of-band pole at the edge
        would count as a mode), refitted, when the rules ask (not for windowed data); then
        one more out-of-band term per side where the data need it (:func:`far_terms`)."""
        w, z, side, ev, info = self.best
        pr = self.prune(w, z, side, ev, info, weak=False) if self.rules.final_prune else None
        if pr is not None and pr[0].size and np.any(pr[2] == 0):
            self.best = self._first_fit(*pr)
        self.best = far_terms(self, self.best, self.collocated)
        return self.best

    @staticmethod
    def _sides_tried(side, tried_side):
        """Whether each side has an out-of-band pole or was tried."""
        return all(tried_side[sd] is not None or np.any(side == sd) for sd in (-1, 1))

    def _first_fit(self, w, z, side):
        """State ``(w, z, side, ev, info)`` of a full search from ``(w, z)``."""
        w, z, ev, info = self.fit(w, z, side)
        return w, z, side, ev, info
