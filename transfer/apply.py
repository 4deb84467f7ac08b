"""Applying a learned style to canonical content motions of any length."""
from __future__ import annotations

import torch

from motioncore.cleanup import cleanup_feet
from motioncore.motion import Motion
from motioncore.representation import FEATURES, decode, encode, facing_angle
from transfer.captions import BANDAI2_CONTENTS, STYLES, caption
from transfer.scheduler import DiffusionScheduler
from transfer.style import StyleConfig, neutralize, stylize

MAX_STEP = 999


def strength_to_step(strength: float) -> int:
    """``--strength`` in (0, 1] -> the noise step K the content is taken to (0.5 -> K = 300, the paper's)."""
    if not 0 < strength <= 1:
        raise ValueError(f"strength: expected a number in (0, 1], got {strength}")
    return max(1, min(MAX_STEP, round(600 * strength)))


def window_starts(n: int, window: int, overlap: int) -> list[int]:
    """Starts of windows covering ``n`` frames; the last window ends at ``n``."""
    if n <= window:
        return [0]
    hop = window - overlap
    starts = list(range(0, n - window, hop))
    return starts + [n - window]


def crossfade(chunks: list[torch.Tensor], starts: list[int], n: int) -> torch.Tensor:
    """Blend overlapping windows ``(L, D)`` into ``(n, D)`` with linear ramps over the overlaps."""
    out = torch.zeros(n, chunks[0].shape[-1])
    total = torch.zeros(n, 1)
    for chunk, s in zip(chunks, starts):
        length = chunk.shape[0]
        w = torch.ones(length)
        if s > 0:  # ramp in over the overlap with the previous window
            prev_end = max(e + c.shape[0] for e, c in zip(starts, chunks) if e < s)
            ramp = max(1, prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2)[1:-1]
        out[s:s + length] += chunk * w[:, None]
        total[s:s + length] += w[:, None]
    return out / total.clamp_min(1e-6)


def classify_caption(motion_encoder, text_encoder, x: torch.Tensor) -> tuple[str, str, list[tuple[str, float]]]:
    """Nearest (content, style) caption of a normalised motion ``(T, D)`` in the motion encoder's space."""
    pairs = [(c, s) for c in BANDAI2_CONTENTS for s in STYLES]
    emb = text_encoder.encode([caption(c, s) for c, s in pairs])
    with torch.no_grad():
        z = motion_encoder(x[None, : min(x.shape[0], 160)])[0]
    sims = emb @ z
    order = sims.argsort(descending=True).tolist()
    c, s = pairs[order[0]]
    return c, s, [(caption(*pairs[i]), float(sims[i])) for i in order[:3]]


def _windows(x: torch.Tensor, window: int, overlap: int) -> tuple[list[int], torch.Tensor]:
    if x.ndim != 2 or x.shape[1] != FEATURES.dim:
        raise ValueError(f"expected features (T, {FEATURES.dim}), got {tuple(x.shape)}")
    starts = window_starts(x.shape[0], window, overlap)
    return starts, torch.stack([x[s:s + window] for s in starts])  # (W, L, D): all windows as one batch


@torch.no_grad()
def neutralize_features(prior, x: torch.Tensor, neutral_text: torch.Tensor, config: StyleConfig, seed: int = 0,
                        window: int = 80, overlap: int = 20) -> torch.Tensor:
    """The neutral version ``(T, D)`` of styled normalised content ``(T, D)``, same path; ``neutral_text (1, E)``."""
    scheduler = DiffusionScheduler(prior.config.num_train_steps)
    starts, parts = _windows(x, window, overlap)
    gen = torch.Generator().manual_seed(seed + 1)
    parts = neutralize(prior, scheduler, parts, neutral_text.expand(len(starts), -1), config, gen)
    return crossfade(list(parts), starts, x.shape[0])


@torch.no_grad()
def apply_style_features(model, prior, x: torch.Tensor, config: StyleConfig, step: int, seed: int = 0,
                         neutral_text: torch.Tensor | None = None, window: int = 80, overlap: int = 20) -> torch.Tensor:
    """Stylise normalised content features ``(T, D)``; ``neutral_text (1, E)`` first neutralises a styled clip."""
    if neutral_text is not None:
        x = neutralize_features(prior, x, neutral_text, config, seed, window, overlap)
    scheduler = DiffusionScheduler(model.config.num_train_steps)
    starts, parts = _windows(x, window, overlap)
    chunks = list(stylize(model, scheduler, parts, config, torch.Generator().manual_seed(seed), step=step))
    return crossfade(chunks, starts, x.shape[0])


def apply_style_motion(model, prior, content: Motion, mean: torch.Tensor, std: torch.Tensor, config: StyleConfig,
                       step: int, seed: int = 0, neutral_text: torch.Tensor | None = None, clean: bool = True) -> Motion:
    """A canonical content motion (canonical fps) -> the stylised canonical motion on the same path."""
    feats = encode(content)
    out = apply_style_features(model, prior, (feats - mean) / std, config, step, seed, neutral_text) * std + mean
    p0 = content.global_positions()[:1].double()
    result = decode(out, content.fps, start_yaw=float(facing_angle(p0)[0]), start_xz=(float(p0[0, 0, 0]), float(p0[0, 0, 2])))
    return cleanup_feet(result, reference=content) if clean else result
