"""The ``sdctrl`` command: ``sdctrl demo`` (the main job), ``sdctrl info FILE`` and
``sdctrl diagnose MODEL.npz DATA.uff [--fe FE.npz]``."""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

__all__ = ["demo", "main"]


def _chain_model():
    """Three masses on springs with a dashpot between masses 1 and 2 (non-proportional damping)."""
    from sdctrl.modal import NormalModeModel

    m = np.array([1.0, 1.5, 0.8])
    k = np.array([4.0e4, 3.0e4, 2.5e4])          # N/m, ground-1, 1-2, 2-3
    M = np.diag(m)
    K = np.array([[k[0] + k[1], -k[1], 0], [-k[1], k[1] + k[2], -k[2]], [0, -k[2], k[2]]])
    C = 2e-5 * K + np.array([[0, 0, 0], [0, 6.0, -6.0], [0, -6.0, 6.0]])
    from scipy.linalg import eigh

    w2, phi = eigh(K, M)
    dofs = ["N1.x", "N2.x", "N3.x"]
    b = np.eye(3)[:, [0, 2]]
    return NormalModeModel(np.diag(w2), phi.T @ C @ phi, phi, phi.T @ b,
                           sensors=dofs, actuators=["N1.x", "N3.x"], shapes=phi, dofs=dofs)


def demo(out: str = "sdctrl-demo", noise: float = 0.01, seed: int = 0, quiet: bool = False) -> str:
    """Run the demonstration job and write its report; return the report path.

    Builds the built-in model, synthesises its measured FRFs (with noise), identifies
    complex modes from them with no initial guess (chapter III), turns them into normal
    modes with a full damping matrix (3.3), compares poles and damping matrix with the
    truth, converts the identified model to a python-control StateSpace and checks it,
    and writes ``report.md`` with a Bode plot PNG (test, truth, identified model) to the
    folder ``out``.

    Parameters
    ----------
    out : str
        Output folder (created).
    noise : float
        Relative complex Gaussian noise added to the synthetic FRFs.
    seed : int
        Seed of the noise.
    quiet : bool
        Do not print progress lines.

    Returns
    -------
    str
        Path of the markdown report.
    """
    from sdctrl.frf import FRF
    from sdctrl.plot import bode
    from sdctrl.report import markdown_table, modes_table

    def say(msg):
        if not quiet:
            print(msg, flush=True)

    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    model = _chain_model()
    say(f"model: {model.n} modes, {model.ns} sensors, {model.na} actuators")
    freq = np.linspace(2.0, 80.0, 1200)
    exact = model.frf(freq, "acceleration")
    rng = np.random.default_rng(seed)
    # multiplicative noise plus a floor 60 dB below each FRF's peak
    scale = noise * np.abs(exact.H) + 1e-3 * np.abs(exact.H).max(axis=0, keepdims=True)
    H = exact.H + scale * (rng.standard_normal(exact.H.shape)
                           + 1j * rng.standard_normal(exact.H.shape)) / np.sqrt(2)
    measured = FRF(freq, H, "acceleration", sensors=exact.sensors, actuators=exact.actuators,
                   collocated=[(0, 0), (2, 1)])
    import sdctrl as sd
    from sdctrl.updating.costs import logls

    t1 = time.perf_counter()
    cm = sd.identify(measured, progress=False)
    say(f"identified {cm.in_band.sum()} modes in the band ({time.perf_counter() - t1:.1f} s)")
    nm = sd.normal_modes(cm, modes=cm.in_band)
    true_p = model.poles
    order = [int(np.argmin(np.abs(true_p - p))) for p in cm.poles[cm.in_band]]
    sg = np.sign(np.sum(nm.cphi * model.cphi[:, order], axis=0))
    gamma_err = (np.linalg.norm(nm.Gamma * np.outer(sg, sg) - model.Gamma[np.ix_(order, order)])
                 / np.linalg.norm(model.Gamma))
    identified = nm.frf(freq, "acceleration")
    cost_id, cost_true = logls(identified, measured), logls(exact, measured)
    say(f"normal modes: damping matrix error {gamma_err:.1e} (Frobenius, relative); logLS "
        f"cost {cost_id:.2e} (the true model's: {cost_true:.2e})")
    sys_ss = nm.to_statespace("acceleration")
    from_ss = FRF.from_system(sys_ss, freq, "acceleration")
    ss_err = np.abs(from_ss.H - identified.H).max() / np.abs(identified.H).max()
    say(f"StateSpace vs identified model FRF: max relative error {ss_err:.1e}")
    png = os.path.join(out, "bode.png")
    bode([measured, exact, from_ss],
         labels=[f"synthetic test ({100 * noise:g}% noise)", "true model",
                 "identified StateSpace"], path=png, title="sdctrl demo: collocated FRFs")
    gam_true = np.array2string(model.Gamma, precision=3, suppress_small=True)
    gam_id = np.array2string(nm.Gamma * np.outer(sg, sg), precision=3, suppress_small=True)
    rows = [(s, a) for s, a in measured.collocated]
    lines = [
        "# sdctrl demo report",
        "",
        (f"Built-in model: {model.n}-mode spring/mass chain with a discrete dashpot "
        "(non-proportional damping), sensors "
        f"{', '.join(model.sensors)}, actuators {', '.join(model.actuators)}."),
        "",
        "## Modes of the model",
        "",
        modes_table(model.poles),
        "",
        "## Synthetic test",
        "",
        f"{freq.size} lines, {freq[0]:g}-{freq[-1]:g} Hz, acceleration/force, "
        f"{100 * noise:g}% multiplicative complex noise and a floor 60 dB below each peak "
        f"(seed {seed}); collocated pairs "
        + ", ".join(f"{measured.sensors[s]}/{measured.actuators[a]}" for s, a in rows) + ".",
        "",
        "## Identification (no initial poles)",
        "",
        "Complex modes by `sd.identify` (chapter III): identified against true poles.",
        "",
        modes_table(cm.poles[cm.in_band], true_p[order]),
        "",
        "## Normal modes and the damping matrix",
        "",
        ("`sd.normal_modes` (3.3): properness enforced by the small Riccati root (3.52), exact "
        "transformation (3.44).  The dashpot couples the modes: `Gamma` is full."),
        "",
        f"True `Gamma` (rad/s):\n\n```\n{gam_true}\n```\n",
        f"Identified `Gamma` (rad/s):\n\n```\n{gam_id}\n```\n",
        (f"Relative error (Frobenius): {gamma_err:.1e}.  logLS cost (3.12) against the test: "
        f"identified {cost_id:.2e}, true model {cost_true:.2e}."),
        "",
        "## State-space model of the identified normal modes",
        "",
        markdown_table(["states", "inputs", "outputs", "max rel. FRF error vs model"],
                       [(sys_ss.nstates, ", ".join(sys_ss.input_labels),
                         ", ".join(sys_ss.output_labels), f"{ss_err:.1e}")]),
        "",
        "![Bode plot](bode.png)",
        "",
        f"Run time: {time.perf_counter() - t0:.2f} s.",
        "",
    ]
    path = os.path.join(out, "report.md")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines))
    say(f"report written to {path}")
    return path


def _info(path: str) -> int:
    from sdctrl.frf import FRF
    from sdctrl.io import read_uff
    from sdctrl.storage import load

    frf = load(path) if path.endswith(".npz") else read_uff(path)
    print(frf)
    if not isinstance(frf, FRF):          # a model or result saved by sdctrl.save
        return 0
    print("sensors:  ", ", ".join(frf.sensors))
    print("actuators:", ", ".join(frf.actuators))
    if frf.collocated:
        print("collocated:", ", ".join(f"{frf.sensors[s]}/{frf.actuators[a]}"
                                       for s, a in frf.collocated))
    return 0


def _diagnose(args) -> int:
    """``sdctrl diagnose``: the effects a saved model lacks against measured FRFs."""
    from sdctrl.diagnosis import diagnose
    from sdctrl.fe import FEModel
    from sdctrl.io import read_uff
    from sdctrl.storage import load

    model = load(args.model)
    frf = load(args.data) if args.data.endswith(".npz") else read_uff(args.data)
    fe = None if args.fe is None else load(args.fe)
    if fe is not None and not isinstance(fe, FEModel):
        raise TypeError(f"--fe: {args.fe} holds a {type(fe).__name__}, not an FEModel")
    d = diagnose(model, frf, fe, max_effects=args.max_effects, progress=not args.quiet)
    report = d.report()
    if args.figure:
        from sdctrl.plot import diagnosis as figure

        figure(d, path=args.figure)
        report = d.report(figure=os.path.basename(args.figure))
    with open(args.report, "w", encoding="utf-8") as fh:
        fh.write(report)
    print(f"error (complex logLS, 3.12): {d.error_before:.4g} before, {d.error_after:.4g} after")
    print(d.table() if d.effects else "no effect added: the model matches the data")
    print(f"report written to {args.report}")
    return 0


def _diagnose_parser(sub) -> None:
    p = sub.add_parser("diagnose", help="trace the residual between a saved model and measured "
                       "FRFs to the effects the model lacks")
    p.add_argument("model", help="model saved by sdctrl.save (.npz)")
    p.add_argument("data", help="measured FRFs (.uff/.unv, or .npz saved by sdctrl.save)")
    p.add_argument("--fe", help="FE model saved by sdctrl.save (.npz): physical candidates")
    p.add_argument("--report", default="diagnosis.md", help="report (default diagnosis.md)")
    p.add_argument("--figure", help="also draw the figure there (e.g. diagnosis.png)")
    p.add_argument("--max-effects", type=int, default=4, help="at most this many effects")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(run=_diagnose)


def main(argv=None) -> int:
    """Entry point of the ``sdctrl`` console script.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status.
    """
    parser = argparse.ArgumentParser(prog="sdctrl", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="run the demonstration job and write a report")
    p.add_argument("--out", default="sdctrl-demo", help="output folder (default: sdctrl-demo)")
    p.add_argument("--noise", type=float, default=0.01, help="relative FRF noise (default 0.01)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p = sub.add_parser("info", help="summarise an FRF file (.uff/.unv or .npz) or a saved model")
    p.add_argument("path")
    _diagnose_parser(sub)
    args = parser.parse_args(argv)
    try:
        if hasattr(args, "run"):
            return args.run(args)
        if args.command == "demo":
            demo(args.out, noise=args.noise, seed=args.seed, quiet=args.quiet)
            return 0
        return _info(args.path)
    except (ValueError, TypeError, OSError) as exc:
        print(f"sdctrl: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
