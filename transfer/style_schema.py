"""Validation of a style file's contents: everything in a ``.v2s`` is untrusted input.

:func:`validate_style` checks the metadata (types, ranges, sizes) and the tensors (names,
dtypes, finiteness, shapes against the rank, the example's size) and raises ``ValueError`` with
one line naming the field. Limits are bounds on what a file may make the program do (an apply must not
cost much more than a learned style's); ``learn``'s options are checked against the same ranges before any
work (:func:`check_config_value`), so learn never writes a file apply refuses.
"""
from __future__ import annotations

import math
from dataclasses import fields

import torch

from motioncore.representation import FEATURES

MAX_TEXT = 500  # characters in a string field
MAX_METADATA = 1 << 20  # characters of JSON metadata
MAX_TENSOR_VALUES = 20_000_000  # all tensors together (a learned style holds about 0.3 M)
MAX_RANK = 64
MAX_EXAMPLE_FRAMES = 20 * 60 * 10  # ten minutes at the canonical 20 fps
ADAPTER_DTYPES = (torch.float16, torch.float32, torch.bfloat16, torch.float64)  # float64: converted on loading
MAX_ADAPTER_VALUE = 1e4  # learned adapters hold values below 10; float16 holds up to 65504
MAX_EXAMPLE_VALUE = 1e3  # example features: metres, m/s, radians and 6D rotation entries
MAX_ITERATIONS = 10_000  # about 10 hours of learning on a 2-core CPU at 3.7 s per iteration
MAX_APPLY_STEPS = 100  # denoising steps per window of one apply pass (the defaults: 6 to stylise, 30 to neutralise)
# StyleConfig field -> (type, low, high): numbers outside are refused
CONFIG_RANGES = {
    "pair_step": (int, 1, 999), "pair_steps": (int, 1, 100), "guidance": (float, 0.0, 20.0),
    "transfer_step": (int, 1, 999), "transfer_steps": (int, 1, 50), "rank": (int, 1, MAX_RANK),
    "lr": (float, 0.0, 1.0), "iterations": (int, 1, MAX_ITERATIONS), "max_seconds": (float, 0.0, 7 * 86400.0),
    "lambda_s": (float, 0.0, 100.0), "content_batch": (int, 1, 64), "window": (int, 8, 400), "rec_windows": (int, 1, 16),
    "seed": (int, -(2**63), 2**63 - 1), "pair_generation": (bool, None, None), "lambda_p": (float, 0.0, 100.0),
    "apply_mode": (str, ("regenerate", "difference"), None), "style_scale": (float, 0.0, 20.0),
    "neutralize_step": (int, 0, 999), "guided_difference": (bool, None, None), "delta_smoothing": (float, 0.0, 100.0),
    "lambda_stat": (float, 0.0, 100.0), "stat_std": (bool, None, None), "stat_reference": (str, ("pair", "neutral"), None),
    "decode": (str, ("rotations", "guarded", "positions"), None), "lambda_dir": (float, 0.0, 100.0),
    "limb_guard": (float, 0.0, 1.0),
}


def _check_value(name: str, value, kind, low, high) -> None:
    if value is None and name.endswith("max_seconds"):  # no time cap
        return
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{name}: expected true or false, got {type(value).__name__}")
        return
    if kind is str:
        if value not in low:
            raise ValueError(f"{name}: expected one of {', '.join(low)}, got {str(value)[:40]!r}")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind is int and not isinstance(value, int)):
        raise ValueError(f"{name}: expected {'an integer' if kind is int else 'a number'}, got {type(value).__name__}")
    if not math.isfinite(value) or not low <= value <= high:
        raise ValueError(f"{name}: expected a number from {low} to {high}, got {value}")


def check_config_value(name: str, value) -> None:
    """``value`` for the StyleConfig field ``name`` within the range a style file is held to; ValueError
    (``expected ..., got ...``, without the field's name) otherwise. The CLI checks its options with it."""
    kind, low, high = CONFIG_RANGES[name]
    try:
        _check_value(name, value, kind, low, high)
    except ValueError as e:
        raise ValueError(str(e).removeprefix(f"{name}: ")) from None


def apply_cost(config: dict) -> tuple[int, int]:
    """Denoising steps per window that a style's ``config`` (fields it lacks: the defaults) makes one apply
    take: ``(to stylise at the strongest --strength, to neutralise a styled clip)``."""
    from dataclasses import asdict

    from transfer.apply import strength_to_step
    from transfer.style import StyleConfig

    c = {**asdict(StyleConfig()), **config}
    k = c["transfer_step"] if c["apply_mode"] == "difference" else strength_to_step(1.0)
    stylise = max(1, round(c["transfer_steps"] * k / c["transfer_step"]))
    neutralise = max(1, round(c["pair_steps"] * c["neutralize_step"] / c["pair_step"])) if c["neutralize_step"] else 0
    return stylise, neutralise


def validate_config(config) -> dict:
    """A style file's ``config`` object -> the same dict, checked field by field (unknown fields refused)."""
    from transfer.style import StyleConfig

    if not isinstance(config, dict):
        raise ValueError(f"config: expected an object, got {type(config).__name__}")  # noqa: TRY004 - one-line CLI error
    known = {f.name for f in fields(StyleConfig)}
    unknown = sorted(repr(str(k)[:40]) for k in config if k not in known)  # repr: a crafted name stays one line
    if unknown:
        raise ValueError(f"config: unknown field(s) {', '.join(unknown[:5])}")
    for name, value in config.items():
        kind, low, high = CONFIG_RANGES[name]
        _check_value(f"config.{name}", value, kind, low, high)
    stylise, neutralise = apply_cost(config)
    if max(stylise, neutralise) > MAX_APPLY_STEPS:
        raise ValueError(f"config: apply would take {stylise} denoising steps per window to stylise and {neutralise} "
                         f"to neutralise (transfer_steps x K / transfer_step, pair_steps x neutralize_step / pair_step); "
                         f"expected at most {MAX_APPLY_STEPS}")
    return config


def check_text(value: str) -> None:
    """ValueError unless ``value`` fits a style file's string fields (``learn --style/--text`` are checked with it)."""
    if len(value) > MAX_TEXT:
        raise ValueError(f"expected at most {MAX_TEXT} characters, got {len(value)}")


def validate_meta(meta) -> dict:
    """The JSON metadata of a style file, checked; returns it."""
    if not isinstance(meta, dict):
        raise ValueError(f"metadata: expected an object, got {type(meta).__name__}")  # noqa: TRY004 - one-line CLI error
    for key in ("style", "content", "source", "base_model_sha256", "stopped_by", "partial"):
        value = meta.get(key)
        if value is not None and (not isinstance(value, str) or len(value) > MAX_TEXT):
            raise ValueError(f"{key}: expected a string of at most {MAX_TEXT} characters")
    validate_config(meta.get("config", {}))
    rank = meta.get("rank", 8)
    _check_value("rank", rank, int, 1, MAX_RANK)
    for key in ("iterations", "iterations_planned", "example_frames"):
        if key in meta:
            _check_value(key, meta[key], int, 0, 10**7)
    tempo = meta.get("tempo")
    if tempo is not None:
        _check_value("tempo", tempo, float, 0.25, 4.0)
    return meta


def validate_tensors(tensors: dict[str, torch.Tensor], rank: int) -> None:
    """Adapter tensors (``*.lora_a (rank, in)``, ``*.lora_b (out, rank)``) and the optional ``example (T, D)``."""
    if not any(k != "example" for k in tensors):
        raise ValueError("tensors: no adapter tensors")
    for name, t in tensors.items():
        if name == "example":
            if t.ndim != 2 or t.shape[1] != FEATURES.dim or not 1 <= t.shape[0] <= MAX_EXAMPLE_FRAMES:
                raise ValueError(f"example: expected (T <= {MAX_EXAMPLE_FRAMES}, {FEATURES.dim}), got {tuple(t.shape)}")
        elif not name.endswith(("lora_a", "lora_b")) or len(name) > 200:
            raise ValueError(f"tensor {name[:60]!r}: not an adapter tensor")
        elif t.ndim != 2 or (t.shape[0] if name.endswith("lora_a") else t.shape[1]) != rank:
            raise ValueError(f"tensor {name}: expected rank {rank}, got shape {tuple(t.shape)}")
        if t.dtype not in ADAPTER_DTYPES:
            raise ValueError(f"tensor {name[:60]}: expected floating point values, got {t.dtype}")
        if not torch.isfinite(t).all():
            raise ValueError(f"tensor {name[:60]}: holds NaN or infinite values")
        bound = MAX_EXAMPLE_VALUE if name == "example" else MAX_ADAPTER_VALUE
        if t.numel() and float(t.abs().max()) > bound:
            raise ValueError(f"tensor {name[:60]}: expected values of magnitude at most {bound:g}, "
                             f"got {float(t.abs().max()):.3g}")


def validate_style(meta, tensors: dict[str, torch.Tensor]) -> dict:
    """Check a whole style file; returns the metadata. ValueError (one line, the field named) otherwise."""
    meta = validate_meta(meta)
    validate_tensors(tensors, int(meta.get("rank", 8)))
    return meta
