"""Structured uncertainty and a robust-stability margin (thesis 5.5), step 7 of the demo."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.report import Check

__all__ = ["BOUND", "Robustness", "robust_strut"]

#: relative bound on every entry of the measured modes' damping matrix
BOUND = 0.2
#: active strut: rate feedback gain (N s/m) and roll-off (Hz)
KV, ROLL_OFF_HZ = 3e4, 200.0
#: random Delta checked inside the guaranteed margin
N_SAMPLES = 100


def _abscissa(sys) -> float:
    return float(np.max(np.linalg.eigvals(sys.A).real))


@dataclass(frozen=True, eq=False)
class Robustness:
    """Robust stability of an active strut loop under uncertain modal damping.

    Parameters
    ----------
    uncertain : UncertainModel
        The hybrid model seen from the strut, damping of the measured modes uncertain.
    controller : control.StateSpace
        Rate feedback of the strut, ``u = -K y``.
    result : RobustResult
        Output of :func:`sdctrl.robust_stability`.
    abscissa : dict
        Largest real part of the poles at the destabilising Delta, ``open`` and
        ``closed`` loop (1/s).
    samples : (int, int)
        Random Delta drawn inside 0.95 x the guaranteed margin, and how many gave a stable
        closed loop.
    """

    uncertain: object
    controller: object
    result: object
    abscissa: dict
    samples: tuple

    @property
    def summary(self) -> str:
        """One line."""
        r = self.result
        return (f"{len(self.uncertain.blocks)} uncertain damping entries; margin "
                f"{r.margin:.3f} <= {r.margin_lower:.3f} x the bounds, critical at "
                f"{r.frequency:.2f} Hz")

    def checks(self) -> list[Check]:
        """Key numbers against the truth (the perturbed models themselves)."""
        r = self.result
        gap = r.margin_lower / r.margin - 1 if r.margin > 0 else np.inf
        n, ok = self.samples
        scale = abs(2 * np.pi * r.frequency) or 1.0
        return [Check("nominal closed loop stable", bool(r.stable), True),
                Check("guaranteed margin (1 / upper bound of mu)", float(r.margin),
                      unit="x the bounds"),
                Check("destabilising size found (1 / lower bound of mu)", float(r.margin_lower),
                      unit="x the bounds"),
                Check("critical frequency (peak of mu)", float(r.frequency), unit="Hz"),
                Check("gap between the bounds", float(gap), 0.0, float(gap), 0.1),
                Check("closed loop at the destabilising Delta is unstable",
                      bool(self.abscissa["closed"] >= -1e-6 * scale), True),
                Check("random Delta within 0.95 x margin giving a stable loop", ok, n)]

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        r = self.result
        return {"margin": r.margin, "margin_lower": r.margin_lower, "stable": r.stable,
                "frequency_hz": r.frequency, "n_blocks": len(self.uncertain.blocks),
                "abscissa_at_delta": dict(self.abscissa), "samples": list(self.samples)}

    def section(self, doc) -> None:
        """Write the robustness section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        """
        r = self.result
        s = doc.section("robustness", "Structured uncertainty and a robust-stability margin")
        s.paragraph(
            f"The strut of the previous section made active: a rate feedback "
            f"`u = -{KV:g} s/(1 + s/wc) y` on its relative displacement (roll-off "
            f"{ROLL_OFF_HZ:g} Hz), on the hybrid model seen from the strut "
            "(`hy.with_io(b=s, c=s.T)`). The measured damping is what the test knows least: "
            f"every entry of the measured modes' `Gamma` is uncertain by +-{100 * BOUND:g}% "
            f"of its size ({len(self.uncertain.blocks)} real parameters, `nm.uncertain(dGamma="
            "...)`, 5.5). `sd.robust_stability` bounds the mixed structured singular value: "
            "the loop is guaranteed stable for every Delta up to `margin` times the bounds, "
            "and a destabilising Delta of size `margin_lower` was found.")
        s.key_numbers(self.checks())
        op = self.abscissa["open"]
        s.paragraph(
            f"At the destabilising Delta the open loop's largest pole real part is {op:.3g} "
            "1/s: " + ("the perturbed damping matrix is no longer positive semi-definite, so "
                       "the margin measures how much damping error the structure itself "
                       "tolerates; bounds that keep `Gamma` positive semi-definite "
                       "(`sdctrl.robust._uncertainty.psd_gamma_bound`, 5.2.2) remove such Delta."
                       if op > 0 else "the open loop is stable there: the controller is what "
                       "the perturbation destabilises."))
        from sdctrl.testbeds._truss import TESTBED_BAND

        lo, hi = TESTBED_BAND
        s.figure(_mu_figure(r, TESTBED_BAND), "Structured singular value over frequency (log "
                 f"axes, the test band {lo:g}-{hi:g} Hz shaded): its peak is 1/margin, at the "
                 f"critical frequency {r.frequency:.2f} Hz (dotted line).", "mu")


def _mu_figure(r, band):
    """mu upper bound on log axes centred on the test band, the critical frequency marked."""
    from matplotlib.figure import Figure

    f, mu = np.asarray(r.mu_freq, float), np.asarray(r.mu, float)
    lo, hi = band
    fc = float(r.frequency)
    xlo = min(lo, fc) / 3 if fc > 0 else lo / 3
    xhi = max(hi, fc) * 3
    keep = (f > 0) & (f >= xlo) & (f <= xhi) & np.isfinite(mu) & (mu > 0)
    fig = Figure(figsize=(8, 3.6), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    ax.axvspan(lo, hi, color="0.92", zorder=0, label=f"test band {lo:g}-{hi:g} Hz")
    ax.loglog(f[keep], mu[keep], ".-", ms=3, lw=0.8, label="upper bound of mu")
    top = max(float(mu[keep].max()) if keep.any() else 1.0, 1 / r.margin_lower)
    ax.axhline(1 / r.margin_lower, color="tab:red", ls="--", lw=0.8,
               label=f"lower bound (destabilising Delta): {1 / r.margin_lower:.3g}")
    ax.axvline(fc, color="k", ls=":", lw=1.0, label=f"critical frequency {fc:.2f} Hz")
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(top * 1e-3, top * 2)          # three decades below the peak: the peak's shape
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("mu (1 / margin)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    return fig


def robust_strut(hybrid, placement, update, progress: bool | None = None) -> Robustness:
    """Step 7: robust stability of the active strut under uncertain measured damping.

    Parameters
    ----------
    hybrid : Hybrid
        The hybrid model.
    placement : Placement
        The chosen bar.
    update : Update
        The updated FE model (strut geometry).
    progress : bool, optional
        Progress bar policy.

    Returns
    -------
    Robustness
    """
    import control

    from sdctrl.robust._stability import robust_stability

    h = hybrid.model
    s = update.result.fe.strut(*placement.bar)
    hs = h.with_io(b=s, c=s.T, actuators=["strut"], sensors=["strut"]).replace(E=None, F=None)
    measured = np.zeros(hs.n, bool)
    m = np.ones(h.n, bool) if getattr(h, "measured", None) is None else h.measured
    measured[:min(m.size, hs.n)] = m[:hs.n]
    dG = np.zeros((hs.n, hs.n))
    block = np.ix_(measured, measured)
    dG[block] = BOUND * np.abs(hs.Gamma[block])
    um = hs.uncertain(dGamma=dG)
    wc = 2 * np.pi * ROLL_OFF_HZ
    K = control.ss(control.tf([KV * wc, 0.0], [1.0, wc]))
    r = robust_stability(um, K, progress=progress)
    P = um.perturbed(r.delta)
    abscissa = {"open": _abscissa(P), "closed": _abscissa(control.feedback(P, K))}
    rng = np.random.default_rng(0)
    nb = len(um.blocks)
    d = rng.uniform(-1, 1, (N_SAMPLES, nb))
    d = 0.95 * r.margin * d / np.abs(d).max(axis=1, keepdims=True)
    ok = sum(_abscissa(control.feedback(um.perturbed(x), K)) < 0 for x in d)
    return Robustness(um, K, r, abscissa, (N_SAMPLES, int(ok)))
