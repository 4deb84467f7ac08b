"""The command line's argument types and shared options: each ``type`` checks a value while parsing (argparse
prints its one-line error after the option's name), each ``add_*`` adds an option several commands take."""
from __future__ import annotations

import argparse


def positive(v: str) -> float:
    try:
        x = float(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {v}") from None
    if not x > 0:  # nan too
        raise argparse.ArgumentTypeError(f"expected a positive number, got {v}")
    return x


def finite_positive(v: str) -> float:
    x = positive(v)
    if x == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite positive number, got {v}")
    return x


def non_negative(v: str) -> float:
    try:
        x = float(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {v}") from None
    if not 0 <= x < float("inf"):  # nan too
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {v}")
    return x


def non_negative_int(v: str) -> int:
    try:
        x = int(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {v}") from None
    if x < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {v}")
    return x


def positive_int(v: str) -> int:
    try:
        x = int(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}") from None
    if x <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return x


def style_option(name: str):
    """An argparse ``type`` for the style config field ``name``: the range a style file is held to
    (:func:`transfer.style_config.check_config_value`), checked while parsing, so learn never writes a file
    apply refuses."""

    def parse(v: str):
        from transfer.style_config import CONFIG_RANGES, check_config_value

        kind, low, high = CONFIG_RANGES[name]
        try:
            value = kind(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'} from {low} "
                                             f"to {high}, got {v}") from None
        try:
            check_config_value(name, value)
        except ValueError as e:  # the value as typed, not as parsed
            raise argparse.ArgumentTypeError(f"{str(e).rsplit(', got ', 1)[0]}, got {v}") from None
        return value

    return parse


def checked(convert, check):
    """An argparse ``type``: ``convert(v)`` then ``check(value)``, whose ValueError ("expected ..., got ...")
    argparse prints after the option's name."""

    def parse(v: str):
        try:
            value = convert(v)
            check(value)
        except ValueError as e:  # the value as typed, not as parsed
            raise argparse.ArgumentTypeError(f"{str(e).rsplit(', got ', 1)[0]}, got {v}" if "expected" in str(e)
                                             else f"expected a number, got {v}") from None
        return value

    return parse


def style_text(v: str) -> str:
    """``learn --style/--text``: no longer than a style file's string fields may be."""
    from transfer.style_file import check_text

    try:
        check_text(v)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return v


def fov(v: str) -> float:
    from lifting.camera import check_fov

    return checked(float, check_fov)(v)


def cutoff(v: str) -> float:
    from lifting.filtering import check_cutoff

    return checked(float, check_cutoff)(v)


def add_rotate(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rotate", type=int, choices=(0, 90, 180, 270), metavar="{0,90,180,270}",  # upright.ROTATIONS
                        help="turn the video's frames this many degrees clockwise before tracking (after the rotation "
                             "tag a phone writes, which is applied); a person upside down or on their side is refused "
                             "naming the turn to give; 0 keeps the frames as they are")


def add_device(parser: argparse.ArgumentParser) -> None:
    from mlcore.device import DEVICE_HELP, DEVICES

    parser.add_argument("--device", choices=DEVICES, default="cpu", help=DEVICE_HELP)


def add_exclude_styles(parser: argparse.ArgumentParser) -> None:
    from mlcore.captions import NEUTRAL_STYLE, STYLES

    parser.add_argument("--exclude-styles", dest="exclude_styles", nargs="+", default=None, metavar="STYLE",
                        choices=[s for s in STYLES if s != NEUTRAL_STYLE],
                        help="leave every clip of these styles (and their captions) out of training, for the unseen-style "
                             "protocol (evaluate --unseen); a resumed run keeps its own")


def explicit_settings(args, config_class) -> dict:
    """The training settings the user gave on the command line (the rest: the resumed run's own, or defaults)."""
    from dataclasses import fields

    explicit = {f.name: getattr(args, f.name) for f in fields(config_class) if getattr(args, f.name, None) is not None}
    if "exclude_styles" in explicit:
        explicit["exclude_styles"] = tuple(sorted(set(explicit["exclude_styles"])))
    return explicit
