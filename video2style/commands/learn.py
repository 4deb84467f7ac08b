"""``video2style learn``: a style from a video or a clip (:func:`video2style.pipeline.learn_file`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from video2style.arguments import add_device, add_rotate, style_option, style_text
from video2style.commands.checks import STYLE_FILE_BYTES, free_space, writable
from video2style.paths import check_outputs

LEARN_SETTINGS = ("max_seconds", "iterations", "seed", "calibrate")  # transfer.style_config.LearnConfig fields
# the apply settings a style file records (transfer.style_config.ApplyConfig fields): each option's metavar and what
# it does (its help, before the default)
APPLY_SETTINGS = {
    "limb_guard": ("METRES", "at apply, a hand or foot whose mean place strays further than this from anywhere between "
                             "the content's and the example's is drawn back"),
    "posture": ("0-1", "at apply, how far each joint's mean place follows the example's (against its neutral pair) "
                       "rather than the style model's change"),
    "arm_gate": ("METRES", "at apply, an arm whose hand is further than this from every place the example's hand takes "
                           "(hands raised where the example walks) keeps the content's motion, easing in over 0.2 m"),
    "arm_travel": ("SHARE", "at apply, a clip that travels over the ground less than this share of the example's speed "
                            "(a wave under a walk's style) keeps its arms' motion, held where the example holds its "
                            "arms"),
    "content_keep": ("0-1", "at apply, the style's change is scaled down (to 3/4, 1/2, 1/4) until the motion encoder "
                            "reads the content's action first again, or with at least this share of its certainty on "
                            "the content; clips it does not know are left as they are"),
}


def add_parser(sub) -> None:
    """The ``learn`` command's parser, on the subparsers ``sub``."""
    from transfer.style_config import MIN_ITERATIONS, ApplyConfig, LearnConfig
    from video2style.interchange import add_arguments as add_clip_format_arguments

    lr = sub.add_parser("learn", help="learn a style from a video or a BVH clip",
                        epilog="examples:\n  video2style learn old_man.mp4 --style old -o old.v2s\n"
                               "  video2style learn strut.bvh --style strutting --text 'a person walks'\n"
                               "  video2style learn diver.mp4 --style 'scuba diver' --start 0.6   # skip the first 0.6 s\n\n"
                               "The budget is iterations, so the same input gives the same style file on any machine;\n"
                               "a style learned in too few iterations is refused unless --allow-partial.",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    lr.add_argument("input", type=Path, help="video (.mp4, .mov, ...), .bvh, or an FBX/GLB/glTF clip")
    lr.add_argument("--style", type=style_text, help="a name for the style, e.g. 'old', kept in the style file; learning does not use it "
                    "unless the style's config turns on lambda_s (default: from the file name)")
    lr.add_argument("--text", type=style_text, help="what the person does, e.g. 'a person walks' (default: recognised)")
    lr.add_argument("-o", "--output", type=Path, help="style file (default: <input name>.v2s)")
    lr.add_argument("--calibrate", action="store_true", default=None,  # None: not given, as every setting here
                    help="scale the style so results differ from their content as much as the example differs from "
                         "its neutral version (measured on neutral clips of other actions; more style, the action "
                         "read less often: docs/results.md#calibrated-amount-opt-in)")
    lr.add_argument("--iterations", type=style_option("iterations"),
                    help=f"fine-tuning iterations: the budget, the same on any machine (default: {LearnConfig.iterations})")
    lr.add_argument("--max-seconds", type=style_option("max_seconds"),
                    help="optional wall-clock cap on learning; if it cuts learning short, learn fails unless --allow-partial")
    lr.add_argument("--allow-partial", action="store_true",
                    help=f"keep a style cut short by --max-seconds or learned in fewer than {MIN_ITERATIONS} iterations")
    lr.add_argument("--seed", type=style_option("seed"), help=f"random seed (default: {LearnConfig.seed})")
    for name, (metavar, what) in APPLY_SETTINGS.items():
        lr.add_argument(f"--{name.replace('_', '-')}", type=style_option(name), metavar=metavar,
                        help=f"{what} (default: {getattr(ApplyConfig, name)}; 0: off)")
    lr.add_argument("--start", type=float, help="use the input from this time on, in seconds")
    lr.add_argument("--end", type=float, help="use the input up to this time, in seconds")
    lr.add_argument("--joint-map", type=Path, help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON map of canonical role -> your joint name overrides the roles it names")
    add_rotate(lr)
    add_device(lr)
    add_clip_format_arguments(lr)
    lr.set_defaults(func=run)


def run(args) -> None:
    from dataclasses import replace

    from motioncore.retarget import load_joint_map
    from transfer.style_config import ApplyConfig, LearnConfig
    from video2style.interchange import as_bvh
    from video2style.pipeline import learn_file

    config = replace(LearnConfig(), **_given(args, LEARN_SETTINGS))  # the rest: the configs' defaults
    apply_config = replace(ApplyConfig(), **_given(args, APPLY_SETTINGS))
    out = writable(args.output or Path(args.input.stem + ".v2s"), "-o")
    check_outputs([("-o", out)], [("the input", args.input), ("the --joint-map", args.joint_map)])
    free_space(out, STYLE_FILE_BYTES, "-o")
    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    args.input = as_bvh(args, args.input)  # an FBX/glTF clip: its action as BVH
    summary = learn_file(args.input, out, args.style, args.text, config, joint_map, allow_partial=args.allow_partial,
                         span=(args.start, args.end), show_bar=True, device=args.device, rotate=args.rotate,
                         apply_config=apply_config)
    if summary["partial"]:
        print(f"warning: {summary['partial']} (kept because of --allow-partial)", file=sys.stderr)
    print(learned_line(summary, out))


def _given(args, names) -> dict:
    """The settings of ``names`` the command line gave (an option not given is None)."""
    return {name: getattr(args, name) for name in names if getattr(args, name) is not None}


def learned_line(summary: dict, out: Path) -> str:
    """learn's closing line: the content said as fact only when it was given or recognised with confidence."""
    sure = summary.get("content_confident", True)
    line = (f"learned style {summary['style']!r}" + (f" ({summary['content']})" if sure else "")
            + f" in {summary['seconds']:.0f} s, {summary['iterations']} iterations -> {out} "
              f"({summary['bytes'] / 1024:.0f} KiB)")
    if not sure:
        line += (f"; what the person does was not recognised with confidence (closest guess: {summary['content']!r}): "
                 "if that is wrong, learn again with --text 'a person ...'")
    return line
