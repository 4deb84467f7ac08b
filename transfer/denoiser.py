"""MDM-style denoiser: (noisy motion, step, text embedding) -> predicted clean motion x0."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
from safetensors.torch import load_file
from torch import nn

from mlcore.checkpoints import load_config
from motioncore.representation import FEATURES, positions_from_rotations
from transfer.layers import Block, MotionEmbedding, sinusoidal


@dataclass
class DenoiserConfig:
    feature_dim: int = FEATURES.dim
    text_dim: int = 384
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff: int = 512
    dropout: float = 0.1
    num_train_steps: int = 1000
    derive_positions: bool = False  # x0's joint-position channels are the joints its rotation channels and root height
    # place (motioncore.representation.positions_from_rotations), not predicted: the two channel sets cannot disagree
    # (needs the features' normalisation, :meth:`Denoiser.set_normalization`; measured as a stage of the shipped prior:
    # docs/archive/RESULTS-notebook.md#planted-feet-at-sampling-issue-24, "Derived positions as a training stage")


class Denoiser(nn.Module):
    """``forward(x_t (B, T, D), t (B,), text (B, E) | None, valid (B, T) | None) -> x0 (B, T, D)``.

    The step and text embeddings are summed into one condition token placed before the motion
    tokens. ``text=None`` (or rows of ``drop`` set True) is the unconditional model used for
    classifier-free guidance. With ``config.derive_positions`` the output's joint-position channels are derived from
    its rotation channels (the canonical layout, :data:`motioncore.representation.FEATURES`).
    """

    def __init__(self, config: DenoiserConfig):
        super().__init__()
        self.config = c = config
        self.embed = MotionEmbedding(c.feature_dim, c.width)
        self.time_mlp = nn.Sequential(nn.Linear(c.width, c.width), nn.SiLU(), nn.Linear(c.width, c.width))
        self.text_proj = nn.Linear(c.text_dim, c.width)
        self.blocks = nn.ModuleList([Block(c.width, c.heads, c.ff, c.dropout) for _ in range(c.layers)])
        self.norm = nn.LayerNorm(c.width)
        self.out = nn.Linear(c.width, c.feature_dim)
        if c.derive_positions:
            if c.feature_dim != FEATURES.dim:
                raise ValueError(f"Denoiser: derive_positions expected feature_dim {FEATURES.dim}, got {c.feature_dim}")
            # the features' normalisation, set from the training data (not saved with the weights, which keep it beside)
            self.register_buffer("feature_mean", torch.zeros(c.feature_dim), persistent=False)
            self.register_buffer("feature_std", torch.ones(c.feature_dim), persistent=False)
            self.normalization_set = False

    def set_normalization(self, mean: torch.Tensor, std: torch.Tensor) -> Denoiser:
        """The features' mean and std ``(D,)`` that :attr:`DenoiserConfig.derive_positions` needs; returns self."""
        if mean.shape != (self.config.feature_dim,) or std.shape != (self.config.feature_dim,):
            raise ValueError(f"set_normalization: expected mean, std ({self.config.feature_dim},), got "
                             f"{tuple(mean.shape)}, {tuple(std.shape)}")
        if self.config.derive_positions:
            self.feature_mean.copy_(mean)
            self.feature_std.copy_(std)
            self.normalization_set = True
        return self

    def derived(self, x0: torch.Tensor) -> torch.Tensor:
        """``x0 (B, T, D)`` (normalised) with its joint-position channels replaced by the joints its rotation channels
        and root height place (:func:`derive_position_channels`)."""
        if not self.normalization_set:
            raise RuntimeError("Denoiser: derive_positions needs the features' normalisation (set_normalization) first")
        return derive_position_channels(x0, self.feature_mean, self.feature_std)

    def forward(self, x_t, t, text=None, valid=None, drop=None):
        b, _, d = x_t.shape
        if d != self.config.feature_dim:
            raise ValueError(f"Denoiser: expected x_t (B, T, {self.config.feature_dim}), got {tuple(x_t.shape)}")
        cond = self.time_mlp(sinusoidal(torch.as_tensor(t, device=x_t.device).expand(b), self.config.width))
        if text is not None:
            txt = self.text_proj(text)
            if drop is not None:
                txt = txt * (~drop)[:, None].to(txt.dtype)
            cond = cond + txt
        h = torch.cat([cond[:, None], self.embed(x_t, offset=1)], dim=1)
        full_valid = None
        if valid is not None:
            full_valid = torch.cat([torch.ones(b, 1, dtype=torch.bool, device=x_t.device), valid], dim=1)
        for blk in self.blocks:
            h = blk(h, full_valid)
        x0 = self.out(self.norm(h[:, 1:]))
        return self.derived(x0) if self.config.derive_positions else x0


def derive_position_channels(x0: torch.Tensor, mean: torch.Tensor, std: torch.Tensor) -> torch.Tensor:
    """``x0 (*, T, D)``, features normalised with ``mean, std (D,)`` (the canonical layout,
    :data:`motioncore.representation.FEATURES`) -> the same with the joint-position channels replaced by the joints
    the rotation channels and root height place (:func:`motioncore.representation.positions_from_rotations`): the
    two channel sets then agree. Differentiable; ``x0``'s dtype and device."""
    if x0.dim() < 2 or x0.shape[-1] != FEATURES.dim or mean.shape != (FEATURES.dim,) or std.shape != (FEATURES.dim,):
        raise ValueError(f"derive_position_channels: expected x0 (*, T, {FEATURES.dim}), mean and std ({FEATURES.dim},), "
                         f"got {tuple(x0.shape)}, {tuple(mean.shape)}, {tuple(std.shape)}")
    mean, std, sl = mean.to(x0.device, torch.float32), std.to(x0.device, torch.float32), FEATURES.positions
    raw = x0.float() * std + mean
    pos = (positions_from_rotations(raw).flatten(-2) - mean[sl]) / std[sl]
    return torch.cat([x0[..., :sl.start], pos.to(x0.dtype), x0[..., sl.stop:]], dim=-1)


def load_denoiser(path: Path) -> tuple[Denoiser, dict[str, torch.Tensor]]:
    """Load a denoiser; returns the model and any extra tensors (e.g. normalisation stats)."""
    config = load_config(path, DenoiserConfig)
    model = Denoiser(config)
    tensors = load_file(str(path))
    own = set(model.state_dict())
    model.load_state_dict({k: v for k, v in tensors.items() if k in own})
    extra = {k: v for k, v in tensors.items() if k not in own}
    if config.derive_positions:
        if "norm.mean" not in extra or "norm.std" not in extra:
            raise ValueError(f"{path}: a denoiser with derive_positions needs norm.mean and norm.std beside its weights")
        model.set_normalization(extra["norm.mean"], extra["norm.std"])
    return model.eval(), extra
