"""A style file (``.v2s``): a learned style's adapter tensors (safetensors) and JSON metadata, how it is written,
read and checked, and the style model it makes (:func:`style_model`).

Everything in a ``.v2s`` is untrusted input. :func:`validate_style` checks the metadata (types, ranges, sizes)
and the tensors (names, dtypes, finiteness, shapes against the rank, the example's size) and raises ``ValueError``
with one line naming the field. Limits are bounds on what a file may make the program do (an apply must not cost
much more than a learned style's); ``learn``'s options are checked against the same ranges before any work
(:func:`transfer.style_config.check_config_value`), so learn never writes a file apply refuses.
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import load_file, save

from motioncore.representation import FEATURES
from transfer.lora import add_lora, load_lora_state, set_gain
from transfer.style_config import (
    CONFIG_RANGES,
    LEARNED_WITHOUT,
    MAX_RANK,
    ApplyConfig,
    LearnConfig,
    check_value,
    current_names,
    split_config,
    strength_to_step,
)

MAX_TEXT = 500  # characters in a string field
MAX_METADATA = 1 << 20  # characters of JSON metadata
MAX_TENSOR_VALUES = 20_000_000  # all tensors together (a learned style holds about 0.3 M)
MAX_EXAMPLE_FRAMES = 20 * 60 * 10  # ten minutes at the canonical 20 fps
ADAPTER_DTYPES = (torch.float16, torch.float32, torch.bfloat16, torch.float64)  # float64: converted on loading
MAX_ADAPTER_VALUE = 1e4  # learned adapters hold values below 10; float16 holds up to 65504
MAX_EXAMPLE_VALUE = 1e3  # example features: metres, m/s, radians and 6D rotation entries
MAX_APPLY_STEPS = 100  # denoising steps per window of one apply pass (the defaults: 6 to stylise, 30 to neutralise)


@dataclass
class Style:
    """A learned style: adapter tensors and what is needed to apply them."""

    adapters: dict[str, torch.Tensor]
    meta: dict = field(default_factory=dict)
    example: torch.Tensor | None = None  # the style example, canonical features (T, D), for previews
    source: Path | None = None  # the file it was loaded from: errors about its contents name it
    posture_shift: torch.Tensor | None = None  # (C,): the example's time-mean change of the body channels against its
    # neutral pair, normalised (transfer.posture.match_posture); None in files learned before 2026-12-05

    @property
    def gain(self) -> float:
        """The calibrated amount ``apply`` multiplies the style's change by (:mod:`transfer.amount`; 1: none)."""
        return float(self.meta.get("amount", {}).get("gain", 1.0))

    def configs(self) -> tuple[LearnConfig, ApplyConfig]:
        """The configs the style was learned with (fields its file lacks: today's defaults, or how learning ran
        before they existed, :data:`transfer.style_config.LEARNED_WITHOUT`). A loaded file's config was validated by
        :meth:`load`."""
        return split_config(LEARNED_WITHOUT | self.meta.get("config", {}))

    def save(self, path: Path) -> None:
        """Write atomically under a temporary name of its own (two writers never share one). A full or
        read-only disk raises OSError naming ``path`` (the serialised bytes are written by Python, not by
        safetensors, whose own error is a traceback-only SafetensorError)."""
        from motioncore.files import atomic_output

        tensors = {k: v.to("cpu", torch.float16).contiguous() for k, v in self.adapters.items()}
        if self.example is not None:
            tensors["example"] = self.example.to("cpu", torch.float32).contiguous()
        if self.posture_shift is not None:
            tensors["posture_shift"] = self.posture_shift.to("cpu", torch.float32).contiguous()
        data = save(tensors, metadata={"video2style": json.dumps(self.meta)})
        try:
            with atomic_output(path, ".tmp") as tmp:
                tmp.write_bytes(data)
        except OSError as e:
            raise OSError(e.errno, e.strerror or str(e), str(path)) from None

    @staticmethod
    def load(path: Path) -> Style:
        """Read and validate a style file (:func:`validate_style`): it is untrusted input."""
        from motioncore.files import check_regular_file

        path = Path(path)
        check_regular_file(path, "style file")  # a FIFO would hang open() for good
        try:
            with safe_open(str(path), framework="pt") as f:
                raw = (f.metadata() or {}).get("video2style")
                sizes = [math.prod(f.get_slice(k).get_shape()) for k in f.keys()]  # noqa: SIM118 - not a dict
            if raw is None or len(raw) > MAX_METADATA:
                raise ValueError("no video2style metadata" if raw is None else "metadata too large")
            if sum(sizes) > MAX_TENSOR_VALUES:
                raise ValueError(f"tensors too large ({sum(sizes)} values)")
            meta = json.loads(raw)
            tensors = load_file(str(path))
        except FileNotFoundError:
            raise FileNotFoundError(f"{path}: no such style file") from None
        except Exception as e:  # noqa: BLE001 - safetensors raises its own errors on garbage (RecursionError included)
            raise ValueError(f"{path}: not a video2style style file ({' '.join(str(e).split())[:200]})") from None
        try:
            if isinstance(meta, dict) and isinstance(meta.get("config"), dict):
                meta["config"] = current_names(meta["config"])  # a file from before the step fields were renamed
            validate_style(meta, tensors)
        except ValueError as e:
            raise ValueError(f"{path}: invalid style file: {' '.join(str(e).split())}") from None  # one line, always
        example, shift = tensors.pop("example", None), tensors.pop("posture_shift", None)
        return Style({k: v.float() for k, v in tensors.items()}, meta, None if example is None else example.float(), path,
                     None if shift is None else shift.float())


def style_model(prior, style: Style, gain: float = 1.0):
    """A copy of the prior with the style's adapters loaded (eval mode)."""
    rank = int(style.meta.get("rank", 8))
    model = copy.deepcopy(prior)
    add_lora(model, rank=rank)
    try:
        load_lora_state(model, style.adapters)
    except ValueError as e:
        if style.source is None:
            raise
        raise ValueError(f"{style.source}: invalid style file: {e}") from None
    set_gain(model, gain)
    return model.eval()


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def apply_cost(config: dict) -> tuple[int, int]:
    """Denoising steps per window that a style's ``config`` (fields it lacks: the defaults) makes one apply
    take: ``(to stylise at the strongest --strength, to neutralise a styled clip)``."""
    c = {**asdict(LearnConfig()), **asdict(ApplyConfig()), **config}
    k = c["transfer_noise_step"] if c["apply_mode"] == "difference" else strength_to_step(1.0)
    stylise = max(1, round(c["transfer_ddim_steps"] * k / c["transfer_noise_step"]))
    neutralise = max(1, round(c["pair_ddim_steps"] * c["neutralize_step"] / c["pair_noise_step"])) if c["neutralize_step"] else 0
    return stylise, neutralise


def validate_config(config) -> dict:
    """A style file's ``config`` object -> the same dict, checked field by field (unknown fields refused)."""
    if not isinstance(config, dict):
        raise ValueError(f"config: expected an object, got {type(config).__name__}")  # noqa: TRY004 - one-line CLI error
    unknown = sorted(repr(str(k)[:40]) for k in config if k not in CONFIG_RANGES)  # repr: a crafted name stays one line
    if unknown:
        raise ValueError(f"config: unknown field(s) {', '.join(unknown[:5])}")
    for name, value in config.items():
        kind, low, high = CONFIG_RANGES[name]
        check_value(f"config.{name}", value, kind, low, high)
    stylise, neutralise = apply_cost(config)
    if max(stylise, neutralise) > MAX_APPLY_STEPS:
        raise ValueError(f"config: apply would take {stylise} denoising steps per window to stylise and {neutralise} "
                         f"to neutralise (transfer_ddim_steps x K / transfer_noise_step, pair_ddim_steps x neutralize_step / pair_noise_step); "
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
    check_value("rank", rank, int, 1, MAX_RANK)
    for key in ("iterations", "iterations_planned", "example_frames"):
        if key in meta:
            check_value(key, meta[key], int, 0, 10**7)
    amount = meta.get("amount")
    if amount is not None:
        from transfer.amount import GAIN_RANGE

        if not isinstance(amount, dict) or set(amount) - {"gain", "target", "reached"}:
            raise ValueError("amount: expected an object with gain, target and reached")
        check_value("amount.gain", amount.get("gain", 1.0), float, *GAIN_RANGE)
        for key in ("target", "reached"):
            check_value(f"amount.{key}", amount.get(key, 0.0), float, 0.0, 1e3)
    tempo = meta.get("tempo")
    if tempo is not None:
        check_value("tempo", tempo, float, 0.25, 4.0)
    return meta


def validate_tensors(tensors: dict[str, torch.Tensor], rank: int) -> None:
    """Adapter tensors (``*.lora_a (rank, in)``, ``*.lora_b (out, rank)``), the optional ``example (T, D)`` and the
    optional ``posture_shift (C,)``."""
    from transfer.style_losses import STAT_CHANNELS

    if not any(k not in ("example", "posture_shift") for k in tensors):
        raise ValueError("tensors: no adapter tensors")
    for name, t in tensors.items():
        if name == "example":
            if t.ndim != 2 or t.shape[1] != FEATURES.dim or not 1 <= t.shape[0] <= MAX_EXAMPLE_FRAMES:
                raise ValueError(f"example: expected (T <= {MAX_EXAMPLE_FRAMES}, {FEATURES.dim}), got {tuple(t.shape)}")
        elif name == "posture_shift":
            if t.shape != (len(STAT_CHANNELS),):
                raise ValueError(f"posture_shift: expected ({len(STAT_CHANNELS)},), got {tuple(t.shape)}")
        elif not name.endswith(("lora_a", "lora_b")) or len(name) > 200:
            raise ValueError(f"tensor {name[:60]!r}: not an adapter tensor")
        elif t.ndim != 2 or (t.shape[0] if name.endswith("lora_a") else t.shape[1]) != rank:
            raise ValueError(f"tensor {name[:60]!r}: expected rank {rank}, got shape {tuple(t.shape)}")
        if t.dtype not in ADAPTER_DTYPES:
            raise ValueError(f"tensor {name[:60]!r}: expected floating point values, got {t.dtype}")
        if not torch.isfinite(t).all():
            raise ValueError(f"tensor {name[:60]!r}: holds NaN or infinite values")
        bound = MAX_EXAMPLE_VALUE if name in ("example", "posture_shift") else MAX_ADAPTER_VALUE
        if t.numel() and float(t.abs().max()) > bound:
            raise ValueError(f"tensor {name[:60]!r}: expected values of magnitude at most {bound:g}, "
                             f"got {float(t.abs().max()):.3g}")


def validate_style(meta, tensors: dict[str, torch.Tensor]) -> dict:
    """Check a whole style file; returns the metadata. ValueError (one line, the field named) otherwise."""
    meta = validate_meta(meta)
    validate_tensors(tensors, int(meta.get("rank", 8)))
    return meta
