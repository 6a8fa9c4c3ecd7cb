"""The ``sdctrl`` command line: ``demo``, ``identify``, ``diagnose``, ``info`` (arguments
only; the jobs live in :mod:`sdctrl.demo` and :mod:`sdctrl.diagnosis`)."""

from __future__ import annotations

import argparse
import os
import sys

__all__ = ["main"]

_DESCRIPTION = """\
sdctrl turns vibration tests (measured FRFs) and finite element models of lightly
damped structures into control-ready python-control StateSpace models
(E. Balmes, MIT PhD thesis, 1993)."""

_EPILOG = """\
examples:
  sdctrl demo                          the whole story on the built-in testbed
  sdctrl identify test.uff --band 8 60 the modes of your own test, with a report
  sdctrl diagnose model.npz new.uff --fe fe.npz
                                       what a saved model lacks against a new test
  sdctrl info test.uff                 what a UFF file or a saved model holds

Run 'sdctrl COMMAND --help' for the options of a command."""

_DEMO = """\
Run the whole story on the built-in testbed (a truss carrying three plates, 246 DOFs,
31 sensors x 6 shakers) and write a report:

  simulated test with noise -> identification (stabilisation diagram)
  -> normal modes with non-proportional damping -> update of a deliberately wrong
  FE model -> hybrid test/FE model -> D-strut placement and closed-loop RMS
  -> structured uncertainty and a robust-stability margin
  -> diagnosis of an undeclared effect planted in a second test.

Each step prints one line with its time. The folder OUT receives report.html (one
self-contained page: figures embedded, table of contents, every section's key numbers
against the truth), report.md with figures/, summary.json, the models (read back with
sdctrl.load) and the two simulated tests as UFF files. Takes about a minute.
Exit status: 0 when every step ran, 1 when one failed (the report says why)."""

_IDENTIFY = """\
Identify the modes of your own test: no initial poles are needed. Prints a table of
the modes and writes OUT/report.html (stabilisation diagram, test vs identified model,
modes table, complex residues; the normal modes and their full damping matrix when the
file declares collocated sensor/actuator pairs), report.md, summary.json and the models
identified.npz and normal_modes.npz (read back with sdctrl.load). normal_modes.npz holds
the modes of the band (sd.normal_modes(cm, modes=cm.in_band), for the table); to predict
or build a hybrid, use sd.normal_modes(cm) on identified.npz (the default: the band's poles
as normal modes, the others kept as identified residual dynamics).

DATA is a UFF file of FRFs (dataset 58, .uff or .unv) or an FRF saved with sdctrl.save
(.npz)."""

_INFO = "Summarise an FRF file (.uff/.unv or .npz) or a model saved with sdctrl.save."


def _info(path: str) -> int:
    from sdctrl.data._frf import FRF
    from sdctrl.data import read_uff
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


# --- one pair of functions per command: its arguments, its job ------------------------------
def _demo_args(sub) -> None:
    p = sub.add_parser("demo", help="run the whole story on the built-in testbed",
                       description=_DEMO, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="sdctrl-demo", metavar="DIR",
                   help="output folder (default: sdctrl-demo)")
    p.add_argument("--noise", type=float, default=0.01,
                   help="relative noise of the simulated tests (default: 0.01)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default: 0)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")


def _demo_run(args) -> int:
    from sdctrl.demo import demo

    return demo(args.out, noise=args.noise, seed=args.seed, quiet=args.quiet)


def _identify_args(sub) -> None:
    p = sub.add_parser("identify", help="identify the modes of your own test",
                       description=_IDENTIFY,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("path", metavar="DATA", help="FRF file: .uff/.unv (dataset 58) or .npz")
    p.add_argument("--band", type=float, nargs=2, metavar=("F1", "F2"),
                   help="frequency band in Hz (default: every line of the file)")
    p.add_argument("--out", metavar="DIR",
                   help="output folder (default: DATA without extension + '-sdctrl')")
    p.add_argument("--weighting", choices=("auto", "none", "level"), default="auto",
                   help="weight of each line in the fit (sd.identify's weighting): 'auto' "
                        "(default) fits unweighted and level-weighted and keeps the fit "
                        "closer to the data; 'none' or 'level' for one of them")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")


def _identify_run(args) -> int:
    from sdctrl.demo import identify_report

    return identify_report(args.path, band=args.band, out=args.out, quiet=args.quiet,
                           weighting=args.weighting)


def _info_args(sub) -> None:
    p = sub.add_parser("info", help="summarise an FRF file or a saved model", description=_INFO)
    p.add_argument("path", metavar="FILE")


def _info_run(args) -> int:
    return _info(args.path)


def _diagnose(args) -> int:
    """``sdctrl diagnose``: the effects a saved model lacks against measured FRFs."""
    from sdctrl.diagnosis import diagnose
    from sdctrl.fe import FEModel
    from sdctrl.data import read_uff
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
    from sdctrl.demo._diagnosing import diagnosis_page

    page = os.path.splitext(args.report)[0] + ".html"        # the same, one self-contained page
    with open(page, "w", encoding="utf-8") as fh:
        fh.write(diagnosis_page(d, args.model, args.data).to_html())
    print(f"error (complex logLS, 3.12): {d.error_before:.4g} before, {d.error_after:.4g} after")
    print(d.table() if d.effects else "no effect added: the model matches the data")
    print(f"report written to {args.report} and {page}")
    return 0


def _diagnose_parser(sub) -> None:
    p = sub.add_parser("diagnose", help="trace the residual between a saved model and measured "
                       "FRFs to the effects the model lacks")
    p.add_argument("model", help="model saved by sdctrl.save (.npz)")
    p.add_argument("data", help="measured FRFs (.uff/.unv, or .npz saved by sdctrl.save)")
    p.add_argument("--fe", help="FE model saved by sdctrl.save (.npz): physical candidates")
    p.add_argument("--report", default="diagnosis.md",
                   help="markdown report (default diagnosis.md; an HTML page with the same "
                   "stem is written next to it)")
    p.add_argument("--figure", help="also draw the figure there (e.g. diagnosis.png)")
    p.add_argument("--max-effects", type=int, default=4, help="at most this many effects")
    p.add_argument("--quiet", action="store_true", help="no progress bars")


#: command name -> (add its arguments to the subparsers, run it); help lists them in order
COMMANDS = {"demo": (_demo_args, _demo_run), "identify": (_identify_args, _identify_run),
            "diagnose": (_diagnose_parser, _diagnose), "info": (_info_args, _info_run)}


def _parser() -> argparse.ArgumentParser:
    from sdctrl import __version__

    parser = argparse.ArgumentParser(prog="sdctrl", description=_DESCRIPTION, epilog=_EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"sdctrl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add_arguments, _ in COMMANDS.values():
        add_arguments(sub)
    return parser


def main(argv=None) -> int:
    """Entry point of the ``sdctrl`` console script.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 1 a step of a job failed, 2 bad input.
    """
    args = _parser().parse_args(argv)
    try:
        return COMMANDS[args.command][1](args)
    except (ValueError, TypeError, OSError) as exc:
        print(f"sdctrl: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
