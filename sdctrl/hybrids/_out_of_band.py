"""Out-of-band test poles that give an appended FE mode its frequency (5.1.1, beyond it).

The hybrid appends the FE modes the test did not measure as normal modes, with the FE
frequencies times ``kappa`` (the FE's global error).  The identified model may hold, just
outside its band, a pole whose residue has the shape of one of them at the tested sensors:
a mode measured through its flank (a ladder tested over 20-70 Hz has its 70.7 Hz mode
there, which the wrong FE puts at 62.9 Hz, inside the band), or a term that stands for
several modes and has their mixed shape (3.7; below a band cut through a cluster, one pole
at 17.4 Hz for four modes at 15.6-18.6 Hz pairs with one of them at MAC 0.91).  Both pass
the pairing's MAC test; the test itself tells them apart.

Rule (``residual="auto"``): each such pole is tried alone.  It gives its FE mode the
measured frequency only when the ``"identified"`` hybrid built with it is (1) closer to the
identified model at the tested I/O (logLS over the band, 3.12: the appended mode acts there
in that representation) and (2) predicts the held-out channels better on the mean
(leave-one-actuator-out, or -sensor-out, as :mod:`sdctrl.hybrids._auto`).  Neither alone
is enough: on the family of test structures the fit kept a cluster's 68.4 Hz pole whose
held-out score was 29x worse, and the held-out mean kept a 77.6 Hz pole that moved the
fit away from the test.  With one sensor and one actuator the fit decides alone.  The
trials are recorded on ``construction.out_of_band``
(:class:`~sdctrl.hybrids._hybrid_records.OutOfBandTrial`).
"""

from __future__ import annotations

import numpy as np

from sdctrl.hybrids._auto import held_out_scores, reference_lines
from sdctrl.hybrids._hybrid_records import OutOfBandTrial
from sdctrl.updating._costs import logls

__all__ = ["trial_out_of_band"]


def trial_out_of_band(offered, build_full, builder, nm, c, loads, base, *, response=None):
    """The out-of-band poles kept, and the record of every trial.

    Parameters
    ----------
    offered : sequence of (int, float)
        Candidate poles: index in ``nm.residual.poles`` and the paired FE mode's frequency
        (Hz) (:func:`~sdctrl.hybrids._measured_residual.out_of_band_candidates`).
    build_full : callable
        ``build_full(poles) -> HybridModel``: the ``"identified"`` hybrid of the whole test
        with the out-of-band ``poles`` paired.
    builder : callable
        ``builder(poles)``: the fold builder of :func:`~sdctrl.hybrids._auto.held_out_scores`
        with those poles paired.
    nm : NormalModeModel
        The identified model.
    c, loads : ndarray
        Test sensors and inputs on the FE DOFs (``loads`` may be None).
    base : tuple
        ``(nominal logLS, held-out scores per fold or None)`` of the ``"identified"``
        hybrid without out-of-band poles.
    response : ndarray, optional
        ``K^-1 loads``, shared by the folds.

    Returns
    -------
    kept : tuple of int
        Indices in ``nm.residual.poles`` of the poles kept.
    trials : tuple of OutOfBandTrial
    held : dict of int to list of float
        Per kept pole, the held-out scores per fold of the hybrid with it alone (reused
        when it is the only one kept).
    """
    hz, Href = reference_lines(nm)
    nominal0, per0 = base
    kept, trials, held_per = [], [], {}
    for i, fe_hz in offered:
        nominal = logls(build_full((i,)).frf(hz).H, Href)
        held = None
        ok = nominal < nominal0
        if ok and per0 is not None:
            scores = held_out_scores(builder((i,)), nm, c, loads, ("identified",),
                                     response=response)
            held = float(np.mean(scores[2]["identified"]))
            ok = held < float(np.mean(per0))
            held_per[i] = scores[2]["identified"]
        trials.append(OutOfBandTrial(
            pole_hz=float(abs(nm.residual.poles[i]) / (2 * np.pi)), fe_hz=fe_hz,
            nominal=(float(nominal0), float(nominal)),
            held_out=None if held is None else (float(np.mean(per0)), held), kept=bool(ok)))
        if ok:
            kept.append(i)
    return tuple(kept), tuple(trials), {i: held_per[i] for i in kept if i in held_per}
