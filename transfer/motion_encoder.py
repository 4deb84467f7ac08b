"""Motion encoder aligned with the text embedding space (Hu et al. 2024 §3.4.1).

A learned pooling token is put before the motion tokens; the input embedding is the prior's
(copied and frozen, so both models read motion the same way); the output at the token's
position, projected to the text dimension, is the motion's embedding. Training combines the
paper's cosine alignment loss (eq. 8) with an InfoNCE term over the batch (clips sharing a
caption count as positives), and feeds, part of the time, the prior's x0 predictions from
noisy inputs, since the style loss applies the encoder to such predictions.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from safetensors.torch import load_file
from torch import nn
from torch.nn import functional as F

from mlcore.checkpoints import load_config, resumed_config, save_model
from mlcore.dataset import MotionDataset
from mlcore.device import model_device, resolve_device
from mlcore.training import Trainer
from motioncore.representation import FEATURES
from transfer.layers import Block, MotionEmbedding
from transfer.prior import caption_embeddings, load_prior
from transfer.scheduler import DiffusionScheduler


@dataclass
class MotionEncoderConfig:
    feature_dim: int = FEATURES.dim
    text_dim: int = 384
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff: int = 512
    dropout: float = 0.1


class MotionEncoder(nn.Module):
    """``forward(x (B, T, D) normalised features, valid (B, T) | None) -> (B, text_dim)`` unit vectors."""

    def __init__(self, config: MotionEncoderConfig):
        super().__init__()
        self.config = c = config
        self.embed = MotionEmbedding(c.feature_dim, c.width)
        self.token = nn.Parameter(torch.zeros(1, 1, c.width))
        self.blocks = nn.ModuleList([Block(c.width, c.heads, c.ff, c.dropout) for _ in range(c.layers)])
        self.norm = nn.LayerNorm(c.width)
        self.head = nn.Linear(c.width, c.text_dim)

    def forward(self, x: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        if x.ndim != 3 or x.shape[-1] != self.config.feature_dim:
            raise ValueError(f"MotionEncoder: expected (B, T, {self.config.feature_dim}), got {tuple(x.shape)}")
        b = x.shape[0]
        h = torch.cat([self.token.expand(b, -1, -1), self.embed(x, offset=1)], dim=1)
        full = None if valid is None else torch.cat([torch.ones(b, 1, dtype=torch.bool, device=x.device), valid], dim=1)
        for blk in self.blocks:
            h = blk(h, full)
        return F.normalize(self.head(self.norm(h[:, 0])), dim=-1)


@dataclass
class EncoderTrainConfig:
    batch_size: int = 64
    window: int = 80
    lr: float = 3e-4
    warmup: int = 300
    ema: float = 0.995
    temperature: float = 0.07
    nce_weight: float = 1.0
    x0_aug: float = 0.5  # fraction of batches replaced by the prior's x0 predictions
    max_aug_step: int = 700
    seed: int = 0
    exclude_styles: tuple[str, ...] = ()  # styles whose clips and captions the model never sees (unseen protocol)


def alignment_losses(z: torch.Tensor, text: torch.Tensor, same: torch.Tensor, temperature: float):
    """Cosine alignment (eq. 8) and a multi-positive InfoNCE; ``same (B, B)`` marks shared captions."""
    align = (1 - (z * text).sum(-1)).mean()
    logits = z @ text.T / temperature
    target = same.float() / same.float().sum(1, keepdim=True)
    nce = 0.5 * (F.cross_entropy(logits, target) + F.cross_entropy(logits.T, target.T / target.T.sum(1, keepdim=True)))
    return align, nce


def train_motion_encoder(data_dir: Path, prior_path: Path, out_dir: Path, config: EncoderTrainConfig, max_minutes: float,
                         max_steps: int = 10**9, explicit: dict | None = None, progress: bool = True,
                         device: str = "cpu") -> Trainer:
    """Train (or resume) the motion encoder on ``device`` (:func:`mlcore.device.resolve_device`), with the
    prior there too; the model starts from the same seeded weights on any device, batches and noise are drawn
    on the CPU."""
    device = resolve_device(device)
    config = resumed_config(Path(out_dir) / "checkpoint.safetensors", config, explicit or {})
    torch.manual_seed(config.seed)
    data = MotionDataset(data_dir, "train", exclude_styles=tuple(config.exclude_styles))
    text = caption_embeddings(data).to(device)
    captions = [r.caption for r in data.records]
    prior, _, _ = load_prior(prior_path)
    pc = prior.config
    model = MotionEncoder(MotionEncoderConfig(width=pc.width, layers=pc.layers, heads=pc.heads, ff=pc.ff))
    model.embed.load_state_dict(prior.embed.state_dict())
    model.embed.requires_grad_(False)
    model.to(device)
    prior.to(device)
    trainer = Trainer(model, config, out_dir, lr=config.lr, warmup=config.warmup, ema=config.ema)
    trainer.resume(explicit or {})
    gen = torch.Generator().manual_seed(config.seed * 7919 + trainer.step)
    scheduler = DiffusionScheduler(pc.num_train_steps)

    def loss_fn(m, step):  # the batch on the model's device; random numbers drawn on the CPU
        on = model_device(m)
        x, valid, idx = data.sample_windows(config.batch_size, config.window, gen)
        x, valid = x.to(on), valid.to(on)
        if torch.rand((), generator=gen) < config.x0_aug:
            t = torch.randint(config.max_aug_step, (x.shape[0],), generator=gen).to(on)
            with torch.no_grad():
                noise = torch.randn(x.shape, generator=gen).to(on)
                x = prior(scheduler.add_noise(x, noise, t), t, text[idx], valid) * valid[..., None]
        z = m(x, valid)
        same = torch.tensor([[captions[i] == captions[j] for j in idx] for i in idx], device=on)
        align, nce = alignment_losses(z, text[idx], same, config.temperature)
        return align + config.nce_weight * nce, {"align": align.item(), "nce": nce.item()}

    trainer.run(loss_fn, max_steps, max_minutes, progress=progress)
    card = {
        "model": "video2style motion encoder (transformer with a pooling token; text space of all-MiniLM-L6-v2)",
        "data": "Bandai-Namco-Research-Motiondataset-1 and -2, train split, mirrored, 20 fps"
                + (f"; every clip of the styles {', '.join(config.exclude_styles)} left out (clips and captions)"
                   if config.exclude_styles else ""),
        "licence": "CC BY-NC 4.0, inherited from the Bandai-Namco training data",
        "steps": trainer.step, "wall_time_minutes": round(trainer.elapsed / 60, 1),
        "train_config": asdict(config), "model_config": asdict(model.config), "prior": Path(prior_path).name,
        "machine": "2 CPU cores", "date": time.strftime("%Y-%m-%d"),
    }
    save_model(trainer.ema, model.config, out_dir / "motion_encoder.safetensors", card)
    return trainer


def load_motion_encoder(path: Path) -> MotionEncoder:
    model = MotionEncoder(load_config(path, MotionEncoderConfig))
    model.load_state_dict(load_file(str(path)))
    return model.eval()
