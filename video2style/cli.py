"""The ``video2style`` command line: parse, validate, call library functions, report.

Run ``video2style COMMAND --help`` for each command's options and examples.
"""
from __future__ import annotations

import argparse
import sys

from video2style.commands.checks import CliError

# This module is the top parser and the dispatch only: each command is a module of video2style.commands (its parser
# and its work over library calls); its docstring above is the top parser's description.

EXAMPLES = """examples:
  video2style demo                                   # everything on the bundled samples
  video2style models                                 # the pose models for videos, once (or --wheel FILE offline)
  video2style pose walk.mp4 -o walk.bvh --preview walk_pose.mp4
  video2style learn old_man.mp4 --style old -o old.v2s
  video2style apply old.v2s library/ -o out/
  video2style apply --method park --domain elderly library/ -o out/ --variants 3
  video2style batch videos/ --content library/ -o results/
  video2style preview walk.bvh other.bvh -o cmp.mp4  # look at clips side by side
  video2style skeleton my_rig.bvh                    # which joint plays each role (joint maps are rarely needed)
  video2style dataset --bandai2 bandai2.tar.xz --bandai1 bandai1-seen-styles.tar.xz
  video2style train-prior --max-minutes 60           # resumable; run again to continue
  video2style evaluate --quick                       # Bandai-2 protocol: FMD, CRA, SRA, skating
"""


class Terminated(BaseException):
    """SIGTERM, raised where the process is, so that every writer's cleanup runs (exit status 143)."""


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("video2style")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _device_error(args) -> str | None:
    """The one-line error for a ``--device`` this machine cannot run, checked before any work, else None. A batch
    joining a Ray cluster is checked against the cluster's GPUs instead (:func:`video2style.batch_ray.task_device`)."""
    if getattr(args, "device", "cpu") == "cpu" or getattr(args, "ray", None) not in (None, "local"):
        return None
    from mlcore.device import resolve_device

    try:
        resolve_device(args.device)
    except ValueError as e:
        return str(e)
    return None


def build_parser() -> argparse.ArgumentParser:
    """The ``video2style`` parser: ``--version`` and each command's subparser (:data:`video2style.commands.COMMANDS`,
    in that order)."""
    from video2style.commands import COMMANDS

    p = argparse.ArgumentParser(prog="video2style", description=__doc__, epilog=EXAMPLES,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"video2style {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    device_error = _device_error(args)
    if device_error:
        print(f"video2style {args.command}: error: {device_error}", file=sys.stderr)
        return 2
    import signal

    def terminated(signum, frame):  # SIGTERM cleans up like Ctrl-C: temporary files are removed on the way out
        raise Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, terminated)
    except ValueError:  # not the main thread: leave signals alone
        previous = None
    try:
        args.func(args)
    except Terminated:
        print("terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (CliError, ValueError, FileNotFoundError, RuntimeError) as e:
        from motioncore.text import printable
        from video2style.interchange import named

        print(f"video2style {args.command}: error: {printable(named(args, str(e)))}", file=sys.stderr)
        return 1
    except OSError as e:  # a full or read-only disk, a vanished folder: one line naming the path
        from motioncore.text import printable

        where = f"{e.filename}: " if e.filename else ""
        print(f"video2style {args.command}: error: {printable(f'{where}{e.strerror or e}')}", file=sys.stderr)
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if getattr(args, "clip_converter", None) is not None:  # Blender ended, temporary BVH files removed
            args.clip_converter.close()
    return 0


def console_main() -> int:
    """The ``video2style`` console script: :func:`main`, then ``gc.freeze()`` so that the interpreter's exit
    skips a last garbage-collection sweep over every object the imports made (torch's are most of them):
    0.3-0.4 s less at the end of each command on the 2-core box
    (docs/archive/RESULTS-notebook.md#fourth-round-2026-12-02-later-the-interpreters-exit).
    Cleanup still runs (atexit handlers, open files flushed); only objects the process never frees are left
    to the operating system. Tests call :func:`main`, which leaves the collector alone."""
    import gc

    try:
        return main()
    finally:
        gc.freeze()


if __name__ == "__main__":
    sys.exit(console_main())
