"""The apply options, defined once: ``apply`` and ``batch`` both take them, with the same meaning
(:func:`add_apply_options` on each parser, :func:`apply_options` to read them back)."""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ApplyOptions:
    """What ``apply`` (and each item of a ``batch``) is asked to do with a style (:func:`video2style.pipeline.apply_file`)."""

    strength: float = 0.5
    seed: int = 0
    neutralize: str = "auto"
    tempo: str = "off"
    feet: str = "auto"  # the foot cleanup: auto, lock or off (transfer.spans.clean_feet)
    preview: bool = True
    joint_map: Path | None = None
    format: str | None = None  # None: each result in its clip's own format
    armature: str | None = None  # FBX/glTF clips: which armature and action (take) where a file has several
    action: str | None = None

    def check(self) -> None:
        """One-line ValueErrors, before any work: a strength out of 0..1, a tempo number out of range."""
        from transfer.style_config import check_strength
        from transfer.tempo import resolve_tempo

        try:
            check_strength(self.strength)
        except ValueError as e:
            raise ValueError(f"--{e}") from None
        if self.tempo not in ("off", "auto"):
            resolve_tempo(None, self.tempo)  # a number: checked without a style
        from transfer.spans import check_feet

        try:
            check_feet(self.feet)
        except ValueError as e:
            raise ValueError(f"--{e}") from None


def _seed(v: str):
    from video2style.cli import _style_option

    return _style_option("seed")(v)


def add_apply_options(parser: argparse.ArgumentParser) -> None:
    """``--strength``, ``--tempo``, ``--feet``, ``--seed``, ``--neutralize``, ``--no-preview``, ``--joint-map`` and the clip format
    options (``--format``, ``--armature``, ``--action``: :func:`video2style.interchange.add_arguments`)."""
    from video2style.interchange import add_arguments

    parser.add_argument("--strength", type=float, default=0.5,
                        help="0..1: 0 = the content unchanged, 0.5 = the style as learned (default), 1 = stronger style, "
                             "at some cost to the content (docs/RESULTS.md has the trade-off curve)")
    parser.add_argument("--tempo", default="off",
                        help="off (default): keep the content's timing; auto: play it as fast as the style example moved "
                             "(walks and runs; e.g. slower for an elderly style; the clip gets longer); or a factor 0.5-1.5")
    parser.add_argument("--feet", choices=["auto", "lock", "off"], default="auto",
                        help="foot cleanup: auto (default): lock the feet where the content plants them, unless that "
                             "would make them slide more; lock: always; off: the feet as the style moved them "
                             "(spikes are drawn out in every mode)")
    parser.add_argument("--seed", type=_seed, default=0,
                        help="noise seed: the same seed gives the same result (default: %(default)s)")
    parser.add_argument("--neutralize", choices=["auto", "always", "never"], default="auto",
                        help="neutralise styled content first (auto: when the motion encoder recognises a style)")
    parser.add_argument("--no-preview", action="store_true",
                        help="write only the result clips and report.json (no mp4 preview, no player data; apply: no "
                             "index.html)")
    parser.add_argument("--joint-map", type=Path,
                        help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON "
                             "map of canonical role -> your joint name overrides the roles it names")
    add_arguments(parser, formats=True)


def apply_options(args) -> ApplyOptions:
    """The :class:`ApplyOptions` a parsed command line gave (:func:`add_apply_options`), checked."""
    options = ApplyOptions(strength=args.strength, seed=args.seed, neutralize=args.neutralize, tempo=args.tempo,
                           feet=getattr(args, "feet", "auto"), preview=not args.no_preview, joint_map=args.joint_map, format=getattr(args, "format", None),
                           armature=getattr(args, "armature", None), action=getattr(args, "action", None))
    options.check()
    return options
