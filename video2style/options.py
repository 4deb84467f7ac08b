"""The apply request, defined once: :class:`ApplyOptions` is what ``apply``, each item of a ``batch`` (local or on
Ray) and a library caller ask of a style (:meth:`video2style.loaded_style.LoadedStyle.apply`). Each field carries
its command-line option, so ``apply`` and ``batch`` take the same options with the same meaning
(:func:`add_apply_options` on each parser, :func:`apply_options` to read them back): adding an option is adding a
field here."""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field, fields
from pathlib import Path

from transfer.style_config import DEFAULT_STRENGTH


def _seed(v: str):
    from video2style.arguments import style_option

    return style_option("seed")(v)


def _option(*flags: str, read=None, **argument) -> dict:
    """A field's command line: ``parser.add_argument(*flags, **argument)``, the option's default the field's own;
    or, with ``read(args)`` giving the field's value from the parsed arguments, an option of its own sense (a
    ``--no-...`` flag)."""
    return {"flags": flags, "argument": argument, "read": read}


def _format_option() -> dict:
    """A field whose option :func:`video2style.interchange.add_arguments` defines (the clip format options, shared
    with the commands that read clips)."""
    return {"flags": None, "argument": None, "read": None}


@dataclass(frozen=True)
class ApplyOptions:
    """What ``apply`` (and each item of a ``batch``) is asked to do with a style: the method's settings
    (``strength`` 0..1, ``tempo`` off/auto/a factor, ``feet`` auto/lock/off, ``seed``, ``neutralize``
    auto/always/never) and how results are written (``preview``: an mp4 and player data beside each result;
    ``joint_map``: a JSON joint map for the clips' skeletons; ``format``: the results' format, None for each clip's
    own; ``armature``/``action``: which of an FBX/glTF file's). The fields' order is the options' order in
    ``--help``."""

    strength: float = field(default=DEFAULT_STRENGTH, metadata=_option(
        "--strength", type=float,
        help="0..1: 0 = the content unchanged, 0.5 = twice the learned change (default), 1 = four times, "
             "stronger at some cost to the action; 0.25 = once, the default before 2026-12-08 "
             "(docs/results.md#strength-trade-off has the trade-off)"))
    tempo: str = field(default="off", metadata=_option(
        "--tempo",
        help="off (default): keep the content's timing; auto: play it as fast as the style example moved "
             "(walks and runs; e.g. slower for an elderly style; the clip gets longer); or a factor 0.5-1.5"))
    feet: str = field(default="auto", metadata=_option(  # the foot cleanup (transfer.spans.clean_feet)
        "--feet", choices=["auto", "lock", "off"],
        help="foot cleanup: auto (default): lock the feet where the content plants them, unless that "
             "would make them slide more; lock: always; off: the feet as the style moved them "
             "(spikes are drawn out in every mode)"))
    seed: int = field(default=0, metadata=_option(
        "--seed", type=_seed, help="noise seed: the same seed gives the same result (default: %(default)s)"))
    neutralize: str = field(default="auto", metadata=_option(
        "--neutralize", choices=["auto", "always", "never"],
        help="neutralise styled content first (auto: when the motion encoder recognises a style)"))
    preview: bool = field(default=True, metadata=_option(
        "--no-preview", action="store_true", read=lambda args: not args.no_preview,
        help="write only the result clips and report.json (no mp4 preview, no player data; apply: no index.html)"))
    joint_map: Path | None = field(default=None, metadata=_option(
        "--joint-map", type=Path,
        help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON "
             "map of canonical role -> your joint name overrides the roles it names"))
    format: str | None = field(default=None, metadata=_format_option())  # None: each result in its clip's own format
    armature: str | None = field(default=None, metadata=_format_option())  # FBX/glTF clips: which armature and
    action: str | None = field(default=None, metadata=_format_option())  # action (take) where a file has several

    def check(self) -> None:
        """One-line ValueErrors, before any work: a strength out of 0..1, a tempo number out of range, a feet mode
        that is none of auto, lock, off."""
        from transfer.spans import check_feet
        from transfer.style_config import check_strength
        from transfer.tempo import resolve_tempo

        try:
            check_strength(self.strength)
        except ValueError as e:
            raise ValueError(f"--{e}") from None
        if self.tempo not in ("off", "auto"):
            resolve_tempo(None, self.tempo)  # a number: checked without a style
        try:
            check_feet(self.feet)
        except ValueError as e:
            raise ValueError(f"--{e}") from None


def add_apply_options(parser: argparse.ArgumentParser) -> None:
    """Each :class:`ApplyOptions` field's option (``--strength``, ``--tempo``, ``--feet``, ``--seed``, ``--neutralize``,
    ``--no-preview``, ``--joint-map``), then the clip format options (``--format``, ``--armature``, ``--action``:
    :func:`video2style.interchange.add_arguments`)."""
    from video2style.interchange import add_arguments

    for f in fields(ApplyOptions):
        if f.metadata["flags"] is not None:
            own = {} if f.metadata["read"] is not None else {"default": f.default}  # one default: the field's
            parser.add_argument(*f.metadata["flags"], **own, **f.metadata["argument"])
    add_arguments(parser, formats=True)


def apply_options(args) -> ApplyOptions:
    """The :class:`ApplyOptions` a parsed command line gave (:func:`add_apply_options`), checked."""
    options = ApplyOptions(**{f.name: _read(f, args) for f in fields(ApplyOptions)})
    options.check()
    return options


def _read(f, args):
    """A field's value from the parsed arguments: its ``read``, else the attribute of its name (the clip format
    options: None on a parser without them)."""
    if f.metadata["read"] is not None:
        return f.metadata["read"](args)
    return getattr(args, f.name) if f.metadata["flags"] is not None else getattr(args, f.name, None)
