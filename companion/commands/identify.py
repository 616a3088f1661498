"""``usv identify TRAIN.csv [TRAIN2.csv ...] --validate VAL.csv --report DIR [--json]``.

Fits the qLPV model (Eq. 3-4) and the two Table 3 baselines on the training logs, evaluates
J (Eq. 12) on the validation log three ways (free run, 1 s ahead without and with the
UKF-estimated model error), prints the J table (``--json``: as JSON on stdout) and writes
DIR/params.toml (load it with ``models.params_file`` or copy it to
``<state_dir>/model/params.toml``), DIR/report.md and PNG plots.  A bad log gives one line
naming the file, column and row, and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

DEFAULT_WINDOW_S = 2.0
"""Savitzky-Golay window: long enough that the GPS-INS's 0.1 m/s velocity noise left in the sway
regressors does not bias the qLPV sway row, short against the chapter's 10 s sine period
(``docs/tuning.md``)."""
HELP = "identify the qLPV model and baselines from manoeuvre logs; J table, report, params.toml"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("train", nargs="+", type=Path, metavar="TRAIN.csv", help="training log(s)")
    parser.add_argument("--validate", required=True, type=Path, metavar="VAL.csv", help="validation log")
    parser.add_argument("--report", required=True, type=Path, metavar="DIR",
                        help="output directory (params.toml, report.md, PNG plots)")
    parser.add_argument("--json", action="store_true", help="print the J table as JSON instead of text")
    parser.add_argument("--refine", action="store_true",
                        help="also refine the qLPV model by output error (slower); params.toml then "
                             "holds the refined model")
    parser.add_argument("--window", type=float, default=DEFAULT_WINDOW_S, metavar="S",
                        help=f"Savitzky-Golay smoothing window in seconds (default {DEFAULT_WINDOW_S:g})")
    parser.add_argument("--horizon", type=float, default=1.0, metavar="S",
                        help="prediction horizon in seconds (default 1)")
    parser.add_argument("--q-per-step", action="store_true",
                        help="add the chapter's Q every sample instead of reading it as a rate (Q dt)")


def run(args: argparse.Namespace) -> int:
    from companion.cli import UserError
    from companion.models.identify import IdentificationError
    from companion.models.logs import LogError, read_log
    from companion.models.noise_fit import fit_ukf_noise
    from companion.models.pipeline import ProgressBar, format_table, identify_models, ratios, validate
    from companion.models.report import write_report
    from companion.models.ukf import UKFSettings

    if args.window <= 0 or args.horizon <= 0:
        raise UserError("--window and --horizon must be > 0 seconds")
    try:
        train = [read_log(p) for p in args.train]
        val = read_log(args.validate)
    except LogError as exc:
        raise UserError(str(exc)) from None
    bar = ProgressBar("output-error refinement")
    try:
        fits = identify_models(train, window_s=args.window, refine=args.refine, progress=bar)
    except IdentificationError as exc:
        raise UserError(f"identification failed: {exc}") from None
    finally:
        bar.close()
    for fit in fits.values():
        for w in fit.warnings:
            print(f"warning: {w}", file=sys.stderr)
    settings = UKFSettings(q_discretization="per_step" if args.q_per_step else "rate")
    try:
        noise = fit_ukf_noise(fits["qlpv"].model, train, args.horizon, args.window)
        result = validate({n: f.model for n, f in fits.items()}, val, horizon_s=args.horizon,
                          settings=settings, identified_settings=noise)
    except (ValueError, IdentificationError) as exc:
        raise UserError(f"validation failed: {exc}") from None
    command = "usv identify " + " ".join(shlex.quote(a) for a in sys.argv[2:]) if len(sys.argv) > 2 else ""
    try:
        files = write_report(args.report, fits, train, result, command)
    except OSError as exc:
        raise UserError(f"cannot write the report in {args.report}: {exc.strerror or exc}") from None
    if args.json:
        print(json.dumps({"train": [r.name for r in train], "validate": val.name,
                          "reference": result.reference, "horizon_s": args.horizon,
                          "q_discretization": settings.q_discretization,
                          "j": result.table, "active_over_qlpv": ratios(result.table),
                          "held_error_bound": result.held_bound.as_dict() if result.held_bound else None,
                          "ukf_identified": {"q_diag": list(noise.q_diag), "r_diag": list(noise.r_diag),
                                             "j_ahead_active": result.active_identified},
                          "files": [str(f) for f in files]}, indent=2))
    else:
        print(format_table(result.table))
        print(f"J against the {result.reference}; report: {files[1]}; parameters: {files[0]}")
    return 0
