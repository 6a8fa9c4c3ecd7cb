"""The test side of the story: identification and normal modes (steps 2-3).

Each step is a function returning a small record (frozen dataclass) with a one-line
``summary``, its key numbers against the truth (``checks()``, :class:`sdctrl.report.Check`)
and a ``section(doc)`` method that writes its part of the report.  The same steps serve
``sdctrl identify`` on a user's own data, where no truth is known (``truth=None``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.report import Check, modes_table, psd_check

__all__ = ["Identification", "NormalModes", "identify_test", "normal_modes_of"]

#: relative tolerance of the identified frequencies against the truth (noisy test)
FREQ_TOL = 1e-3


# --- step 2: identification ----------------------------------------------------------------
def _match(poles, truth) -> np.ndarray:
    """Index of the nearest true pole of each pole (relative distance)."""
    return np.array([int(np.argmin(np.abs(truth - p) / np.abs(truth))) for p in poles], int)


@dataclass(frozen=True, eq=False)
class Identification:
    """Complex modes identified from a test (chapter III).

    Parameters
    ----------
    frf : FRF
        The test (band used).
    cm : ComplexModeModel
        Identified model.
    truth : ndarray, optional
        True poles in the band (rad/s), None for a user's own data.
    """

    frf: object
    cm: object
    truth: np.ndarray | None = None

    @property
    def poles(self) -> np.ndarray:
        """Identified in-band poles."""
        return self.cm.poles[self.cm.in_band]

    def errors(self) -> tuple[np.ndarray, np.ndarray]:
        """Relative frequency and absolute damping-ratio errors against the nearest truth."""
        t = self.truth[_match(self.poles, self.truth)]
        p = self.poles
        fe = np.abs(p) / np.abs(t) - 1
        ze = -p.real / np.abs(p) + t.real / np.abs(t)
        return fe, ze

    @property
    def summary(self) -> str:
        """One line."""
        lo, hi = self.frf.freq[0], self.frf.freq[-1]
        txt = (f"{self.poles.size} modes in {lo:.5g}-{hi:.5g} Hz "
               f"({int((~self.cm.in_band).sum())} out-of-band), fit error {self.cm.cost:.2%}")
        if self.truth is not None and self.poles.size:
            txt += f"; frequencies within {np.abs(self.errors()[0]).max():.1e} of the truth"
        return txt

    def checks(self) -> list[Check]:
        """Key numbers against the truth (none without truth)."""
        if self.truth is None:
            return [Check("modes identified in the band", int(self.poles.size)),
                    Check("relative fit error", float(self.cm.cost))]
        fe, ze = self.errors()
        distinct = np.unique(_match(self.poles, self.truth)).size
        return [Check("modes identified in the band", int(self.poles.size), int(self.truth.size)),
                Check("distinct true modes matched", distinct, int(self.truth.size)),
                Check("max frequency error", float(np.abs(fe).max()), 0.0,
                      float(np.abs(fe).max()), FREQ_TOL),
                Check("max damping ratio error", 100 * float(np.abs(ze).max()), 0.0,
                      100 * float(np.abs(ze).max()), None, "%", "points")]

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        out = {"n_modes": int(self.poles.size), "frequency_hz": np.abs(self.poles) / (2 * np.pi),
               "damping": -self.poles.real / np.abs(self.poles), "fit_error": float(self.cm.cost)}
        if self.truth is not None:
            fe, ze = self.errors()
            out.update(n_true=int(self.truth.size), max_frequency_error=float(np.abs(fe).max()),
                       max_damping_error=float(np.abs(ze).max()),
                       true_frequency_hz=np.abs(self.truth) / (2 * np.pi))
        return out

    def section(self, doc) -> None:
        """Write the identification section (stabilisation, overlay, table, residues).

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        """
        from sdctrl import plot

        cm, frf = self.cm, self.frf
        s = doc.section("identification", "Identification: complex modes, no initial guess")
        both = None if cm.search is None else cm.search.weighting_logls
        kept = None if cm.search is None else cm.search.weighting
        how = "" if both is not None or kept in (None, "none") else f", weighting={kept!r}"
        s.paragraph(
            f"`sd.identify(frf{how})` (chapter III) fits all {len(frf.sensors)} x "
            f"{len(frf.actuators)} FRFs with common poles: LSCF poles stable over three model "
            f"orders and peaks as a start, then variable projection on the poles, residues by "
            f"linear least squares, removal of poles that fit noise and search of the "
            f"residual for missed modes. Result: {self.poles.size} modes in the band and "
            f"{int((~cm.in_band).sum())} out-of-band poles absorbing the modes beyond its "
            f"edges; relative fit error {cm.cost:.2%}.")
        var = None if cm.search is None else cm.search.weighting_variance
        if both is not None:
            by = (f"mean logLS {both[0]:.3g} unweighted, {both[1]:.3g}" if var is None else
                  f"misfit over the coherence's point variance {var[0]:.3g} unweighted, "
                  f"{var[1]:.3g}")
            s.paragraph(f"Lines weighted: {cm.search.weighting!r}, the fit closer to the data "
                        f"of the two ({by} with each line weighted by the inverse of its "
                        "level).")
        s.key_numbers(self.checks())
        if self.truth is not None:
            s.markdown(modes_table(self.poles, self.truth[_match(self.poles, self.truth)]))
        else:
            s.markdown(modes_table(self.poles))
        st = cm.stabilisation
        if st is not None:
            fig = plot.stabilisation(st.poles, frf, orders=st.orders)
            for p in self.poles:
                fig.axes[0].axvline(abs(p) / (2 * np.pi), color="tab:red", lw=0.6, alpha=0.5)
            s.figure(fig, "Stabilisation diagram: LSCF poles per model order over the CMIF "
                     "(singular values of H); red lines: the identified modes.",
                     "stabilisation")
        s.figure(plot.bode([frf, cm], labels=["test", "identified model"], **_channels(frf),
                           max_cols=3), "Test and identified model at the collocated pairs "
                 "(or the first channels).", "identified_bode")
        k = _most_complex(cm)
        if k is not None:
            band_k = int(np.flatnonzero(cm.in_band).tolist().index(k)) + 1
            a = (cm.collocated[0][1] if cm.collocated
                 else int(np.argmax(np.linalg.norm(cm.residues[k], axis=0))))
            title = (f"mode {band_k} ({cm.frequency[k]:.4g} Hz): phase dispersion "
                     f"{plot.phase_dispersion(cm.residues[k][:, a]):.1f} deg")
            s.figure(plot.complex_residues(cm, mode=k, actuator=a, title=title),
                     f"Residues of the most complex mode, mode {band_k} of the band, "
                     "in the complex plane (thesis Figure 3.5): a real (proportionally damped) "
                     "mode would put them on one line.", "complex_residues")


def _channels(frf) -> dict:
    if frf.collocated:
        return {"channels": [(frf.sensors[s], frf.actuators[a]) for s, a in frf.collocated][:6]}
    n = min(len(frf.sensors), 6)
    return {"channels": [(frf.sensors[i], frf.actuators[0]) for i in range(n)]}


def _most_complex(cm):
    from sdctrl.plot import phase_dispersion

    idx = np.flatnonzero(cm.in_band)
    if idx.size == 0:
        return None
    a = cm.collocated[0][1] if cm.collocated else 0
    disp = [phase_dispersion(cm.residues[j][:, a]) for j in idx]
    return int(idx[int(np.nanargmax(disp))])


def identify_test(frf, band=None, truth=None, progress: bool | None = None,
                  weighting: str = "auto") -> Identification:
    """Step 2: complex modes of a test, no initial poles.

    Parameters
    ----------
    frf : FRF
        The test.
    band : (float, float), optional
        Band (Hz); default all lines.
    truth : ndarray, optional
        True poles (rad/s) to compare with.
    progress : bool, optional
        Progress bar policy (see :mod:`sdctrl.config`).
    weighting : {"auto", "none", "level"}
        Weight of each line in the fit (:func:`sdctrl.identify`).

    Returns
    -------
    Identification
    """
    from sdctrl.identification import identify

    if band is not None:
        frf = frf.band(*band)
    cm = identify(frf, progress=progress, weighting=weighting)
    if truth is not None:
        lo, hi = frf.freq[0], frf.freq[-1]
        f = np.abs(truth) / (2 * np.pi)
        truth = np.asarray(truth)[(f >= lo) & (f <= hi)]
    return Identification(frf, cm, truth)


# --- step 3: normal modes ------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class NormalModes:
    """Normal modes with a full damping matrix from the identified complex modes (3.3).

    Parameters
    ----------
    nm : NormalModeModel
        The normal-mode model (in-band modes).
    test : SimulatedTest, optional
        The truth (undamped FE frequencies, projected damping), None for own data.
    """

    nm: object
    test: object = None

    def _paired(self):
        t = self.test
        idx = np.array([int(np.argmin(np.abs(t.fe_hz - f))) for f in self.nm.frequency])
        sg = np.sign(np.sum(self.nm.cphi * t.cphi[:, idx], axis=0))
        sg[sg == 0] = 1
        return idx, sg

    def gamma_true(self) -> np.ndarray:
        """The true projected damping matrix, in the identified modes' order and signs."""
        idx, sg = self._paired()
        return self.test.Gamma[np.ix_(idx, idx)] * np.outer(sg, sg)

    def close_pair(self) -> tuple[int, int]:
        """Indices of the two modes closest in frequency."""
        f = self.nm.frequency
        i = int(np.argmin(np.diff(f) / f[1:])) if f.size > 1 else 0
        return i, i + 1

    @property
    def summary(self) -> str:
        """One line."""
        i, j = self.close_pair()
        G = self.nm.Gamma
        txt = f"{self.nm.n} normal modes, full damping matrix"
        if self.nm.n > 1:
            txt += f"; close pair coupling Gamma_12 = {G[i, j]:.2f} rad/s"
        if self.test is not None and self.nm.n > 1:
            txt += f" (true {self.gamma_true()[i, j]:.2f})"
        return txt

    def checks(self) -> list[Check]:
        """Key numbers against the truth."""
        nm = self.nm
        out = psd_check(nm)
        if self.test is None or nm.n < 2:
            return out
        idx, _ = self._paired()
        ferr = float(np.abs(nm.frequency / self.test.fe_hz[idx] - 1).max())
        Gt = self.gamma_true()
        i, j = self.close_pair()
        cp = float(nm.Gamma[i, j])
        diag = float(np.abs(np.diag(nm.Gamma) / np.diag(Gt) - 1).max())
        coupling = self.coupling_error()
        return out + [
            Check("max normal-mode frequency error (vs undamped FE modes)", ferr, 0.0, ferr,
                  2e-3),
            Check("close-pair damping coupling Gamma_12", cp, float(Gt[i, j]),
                  cp / Gt[i, j] - 1, 0.02, "rad/s"),
            Check("diagonal of Gamma, max error", diag, 0.0, diag, 0.02),
            Check("couplings, max |dGamma_ij| / |omega_i - omega_j|", coupling, 0.0, coupling,
                  0.01, error_unit="")]

    def coupling_error(self) -> float:
        """Largest error of an off-diagonal ``Gamma_ij`` relative to ``|omega_i - omega_j|``.

        A coupling term changes the response in proportion to this ratio (5.2.2): between
        well-separated modes the test barely determines it, and need not.
        """
        w = 2 * np.pi * self.nm.frequency
        dG = np.abs(self.nm.Gamma - self.gamma_true())
        sep = np.abs(w[:, None] - w[None, :])
        np.fill_diagonal(sep, np.inf)
        return float((dG / sep).max())

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        out = {"n_modes": int(self.nm.n), "frequency_hz": self.nm.frequency,
               "Gamma": self.nm.Gamma}
        if self.test is not None and self.nm.n > 1:
            out["Gamma_true"] = self.gamma_true()
        return out

    def section(self, doc) -> None:
        """Write the normal-modes section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        """
        from sdctrl import plot
        from sdctrl.report import markdown_table

        nm = self.nm
        n_states = nm.to_statespace("acceleration").nstates
        s = doc.section("normal_modes", "Normal modes and the non-proportional damping matrix")
        s.paragraph(
            "`sd.normal_modes(cm, modes=cm.in_band)` (section 3.3): complex modal "
            "observabilities scaled by the collocated pairs (3.24)-(3.25), properness enforced "
            "by the small root of the Riccati equation (3.52), then the exact transformation "
            "(3.44) to mass, damping and stiffness matrices and the undamped reduced "
            "eigenproblem: `Omega` (frequencies), the full `Gamma` (damping, coupling terms "
            "kept) and `cphi`, `phib`. The result is a control-ready model: "
            f"`nm.to_statespace('acceleration')` has {n_states} states ({2 * nm.n} for the "
            "modes, the others the correction modes of `E` and `F`, 2.19-2.24), outputs named "
            "after the "
            "sensors and inputs after the shakers plus `_u`. `modes=cm.in_band` keeps the "
            "modes of the band alone, for this table and its comparisons; a model that "
            "predicts (a hybrid, control near the band edges) uses the default, "
            "`sd.normal_modes(cm)`: the band's poles as normal modes, the poles outside it "
            "kept as identified residual dynamics (`nm.residual`).")
        s.key_numbers(self.checks())
        if self.test is not None:
            s.paragraph(
                "The truth is the true structure's damping matrix projected on its undamped "
                "modes of the band. A coupling term `Gamma_ij` changes the response in "
                "proportion to `Gamma_ij / |omega_i - omega_j|` (5.2.2): it is what the test "
                "determines, and what is checked; couplings between well-separated modes are "
                "small and loosely determined.")
        if nm.n > 1:
            i, j = self.close_pair()
            rows = [(f"Gamma[{a + 1},{b + 1}]", f"{nm.Gamma[a, b]:.4f}",
                     "" if self.test is None else f"{self.gamma_true()[a, b]:.4f}")
                    for a, b in ((i, i), (j, j), (i, j))]
            s.paragraph(f"The closest pair, modes {i + 1} and {j + 1} of the band (undamped "
                        f"natural frequencies {nm.frequency[i]:.2f} and {nm.frequency[j]:.2f} "
                        "Hz, `sqrt(Omega)`; their poles are the identified ones of the "
                        "identification section, which the damping coupling moves): its "
                        "damping block (rad/s).")
            s.markdown(markdown_table(["entry", "identified", "true (projected FE)"], rows))
            if self.test is not None:
                idx, _ = self._paired()
                s.figure(plot.mac(nm.cphi, self.test.cphi[:, idx], names=("identified",
                                                                            "true FE modes")),
                         "MAC between the identified normal modes and the true structure's "
                         "undamped modes at the sensors.", "normal_modes_mac")


def normal_modes_of(ident: Identification, test=None) -> NormalModes:
    """Step 3: normal modes with non-proportional damping of the identified in-band modes.

    Parameters
    ----------
    ident : Identification
        Identified complex modes.
    test : SimulatedTest, optional
        The truth.

    Returns
    -------
    NormalModes
    """
    from sdctrl.identification import normal_modes

    cm = ident.cm
    nm = normal_modes(cm, modes=cm.in_band)
    return NormalModes(nm, test)
