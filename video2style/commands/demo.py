"""``video2style demo``: the whole job on the bundled samples (:func:`video2style.demo.run_demo`)."""
from __future__ import annotations

from pathlib import Path

from video2style.commands.checks import CliError, writable


def add_parser(sub) -> None:
    """The ``demo`` command's parser, on the subparsers ``sub``."""
    m = sub.add_parser("demo", help="run the pipeline on the bundled samples/ (project-made clips)")
    m.add_argument("-o", "--out", type=Path, default=Path("demo_out"), help="output folder (default: ./%(default)s)")
    m.set_defaults(func=run)


def run(args) -> None:
    from video2style.demo import run_demo

    report = run_demo(writable(args.out, "-o", is_dir=True))
    if report.failures:
        raise CliError(f"{len(report.failures)} demo item(s) failed (see the table)")
