"""Training and loading of the text-conditioned motion diffusion prior, and its planted-feet term (a training loss and
a sampling guide)."""
from __future__ import annotations

import csv
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import ClassVar

import torch

from mlcore.checkpoints import resumed_config, save_model
from mlcore.dataset import MotionDataset
from mlcore.device import model_device, resolve_device
from mlcore.training import Trainer
from motioncore.representation import FEATURES, feet_velocity, positions_from_rotations
from transfer.denoiser import Denoiser, DenoiserConfig, load_denoiser
from transfer.scheduler import DiffusionScheduler
from transfer.text_encoder import default_text_encoder


@dataclass
class PriorTrainConfig:
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff: int = 512
    dropout: float = 0.1
    batch_size: int = 32
    window: int = 80  # frames (4 s at 20 fps); Bandai-2 clips average 4.4 s
    lr: float = 2e-4
    warmup: int = 500
    # warmup-stable-decay: the rate falls linearly from lr to lr * lr_final over decay_steps steps from
    # decay_start (the campaign's recipe: 24,000 steps at lr, then 8,000 steps of decay; issue 24)
    decay_start: int = 24_000
    decay_steps: int = 8_000
    lr_final: float = 0.05
    ema: float = 0.999
    text_drop: float = 0.1
    velocity_weight: float = 1.0
    seed: int = 0
    exclude_styles: tuple[str, ...] = ()  # styles whose clips and captions the model never sees (unseen protocol)
    precision: str = "fp32"  # "bf16": the training step's forward under bfloat16 autocast (fp32 weights, optimizer
    # and losses; 1.6x faster on a CPU with avx512_bf16,
    # docs/archive/RESULTS-notebook.md#the-priors-campaign-the-decay-issue-24-2026-12-03-17391915);
    # the validation loss stays fp32
    val_every: int = 250  # steps between validation losses (val.csv); 0 = none
    val_windows: int = 128  # fixed val windows, noise and steps: the validation loss is comparable over a run
    # weight of the FK consistency term (:func:`fk_loss`): the joints implied by the predicted rotation channels
    # against the clip's own joint positions, in cm^2; 0 = off. The campaign's last stage turns it on.
    fk_weight: float = 0.0
    # weight of the foot-contact term (:func:`contact_loss`): how far the feet the model says are planted move over the
    # ground as its rotations and root velocity place them, in (cm/frame)^2 (MDM's term)
    contact_weight: float = 0.0
    # the model's joint-position channels derived from its rotation channels (DenoiserConfig.derive_positions); a
    # stage may turn it on: the weights are the same, the output's position channels are computed instead
    derive_positions: bool = False

    # fields a run may change when it resumes (a new stage of the same run: its precision, FK or contact weight, or a new
    # learning-rate schedule from where it stands, e.g. a higher rate that decays again); any other given setting
    # that differs from the checkpoint's is refused
    STAGE_FIELDS: ClassVar[tuple[str, ...]] = ("precision", "fk_weight", "contact_weight", "lr", "decay_start", "decay_steps",
                                               "lr_final", "derive_positions")


def caption_embeddings(dataset: MotionDataset) -> torch.Tensor:
    """``(N, 384)``: the text embedding of each clip's caption."""
    return default_text_encoder().encode([r.caption for r in dataset.records])


def masked_mse(a: torch.Tensor, b: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
    w = valid[..., None].to(a.dtype)
    return ((a - b) ** 2 * w).sum() / (w.sum() * a.shape[-1]).clamp_min(1)


PRECISIONS = ("fp32", "bf16")


def fk_loss(pred: torch.Tensor, x0: torch.Tensor, valid: torch.Tensor, mean: torch.Tensor,
            std: torch.Tensor) -> torch.Tensor:
    """FK consistency, in cm^2: normalised features ``pred, x0 (B, T, D)`` over ``valid (B, T)``, ``mean, std (D,)``;
    the mean squared distance (per coordinate) between the joints that ``pred``'s rotation channels and root
    height place (:func:`motioncore.representation.positions_from_rotations`) and ``x0``'s joint-position
    channels. Zero for real features: it ties the rotation channels to where the joints are."""
    if pred.shape != x0.shape or pred.shape[-1] != FEATURES.dim or mean.shape != (FEATURES.dim,):
        raise ValueError(f"fk_loss: expected pred, x0 (B, T, {FEATURES.dim}) and mean (D,), got "
                         f"{tuple(pred.shape)}, {tuple(x0.shape)}, {tuple(mean.shape)}")
    mean, std = mean.to(pred), std.to(pred)
    implied = positions_from_rotations(pred * std + mean)  # (B, T, J-1, 3), metres
    target = (x0 * std + mean)[..., FEATURES.positions]
    return masked_mse(100.0 * implied.flatten(-2), 100.0 * target, valid)


def contact_loss(pred: torch.Tensor, valid: torch.Tensor, mean: torch.Tensor, std: torch.Tensor) -> torch.Tensor:
    """Planted feet stay put, in (cm/frame)^2: normalised predicted features ``pred (B, T, D)`` over ``valid (B, T)``,
    ``mean, std (D,)``; how far each foot joint moves over the ground to the next frame as ``pred``'s rotation channels,
    root height and root velocities place it (:func:`motioncore.representation.feet_velocity`), squared, weighted by
    ``pred``'s own contact flags (clipped to 0-1, no gradient through them), as MDM's foot-contact term. It ties the
    root's travel to the feet the model itself says are planted, which no other term couples; attainable at any noise
    level, unlike matching a clip's exact foot velocities."""
    moved, weight = _planted_travel(pred, valid, mean, std, "contact_loss")
    return moved.sum() / (3 * weight.sum()).clamp_min(1)


def _planted_travel(pred, valid, mean, std, caller: str) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`contact_loss`'s sums per clip ``(B,)``: the weighted squared travel, and the weights."""
    if pred.shape[-1] != FEATURES.dim or pred.ndim != 3 or mean.shape != (FEATURES.dim,) or valid.shape != pred.shape[:2]:
        raise ValueError(f"{caller}: expected pred (B, T, {FEATURES.dim}), valid (B, T) and mean (D,), got "
                         f"{tuple(pred.shape)}, {tuple(valid.shape)}, {tuple(mean.shape)}")
    raw = pred * std.to(pred) + mean.to(pred)
    moved = feet_velocity(raw, positions_from_rotations(raw))  # (B, T-1, 4, 3)
    planted = raw[..., :-1, FEATURES.contacts].detach().clamp(0.0, 1.0) * (valid[..., :-1] & valid[..., 1:])[..., None]
    return ((100.0 * moved) ** 2 * planted[..., None]).sum((1, 2, 3)), planted.sum((1, 2))


def contact_guide(mean: torch.Tensor, std: torch.Tensor, rate: float, iterations: int):
    """A sampling guide (:func:`transfer.sampling.denoising_steps`) that keeps the feet the prior says are planted in
    place: each x0 prediction ``(B, T, D)`` (normalised with ``mean, std (D,)``) takes ``iterations`` gradient steps of
    size ``rate`` down its own :func:`contact_loss`, each clip's alone (so a clip's draw does not depend on the
    others in its batch). Only the x0 prediction moves, through the motion code's forward kinematics; the denoiser
    is not differentiated. The rotation channels are planted (what ``representation.decode`` reads); the position
    channels keep their own feet (guiding both was measured,
    docs/archive/RESULTS-notebook.md#planted-feet-at-sampling-issue-24)."""
    if rate < 0 or iterations < 0:
        raise ValueError(f"contact_guide: expected rate >= 0 and iterations >= 0, got {rate}, {iterations}")

    def guide(x0: torch.Tensor) -> torch.Tensor:
        valid = torch.ones(x0.shape[:2], dtype=torch.bool, device=x0.device)
        with torch.enable_grad():
            for _ in range(iterations):
                x = x0.detach().requires_grad_(True)
                moved, weight = _planted_travel(x, valid, mean, std, "contact_guide")
                (grad,) = torch.autograd.grad((moved / (3 * weight).clamp_min(1)).sum(), x)
                x0 = x - rate * grad
        return x0.detach()

    return guide


def diffusion_loss(model, scheduler, x0, valid, text, drop, velocity_weight, generator, precision: str = "fp32",
                   fk_weight: float = 0.0, norm: tuple[torch.Tensor, torch.Tensor] | None = None,
                   contact_weight: float = 0.0):
    """x0-prediction loss at random steps, plus a loss on frame-to-frame differences: ``x0 (B, T, D)``,
    ``valid (B, T)``, ``text (B, E)``, ``drop (B,)``, moved to the model's device; the steps and the noise are
    drawn on the CPU from ``generator``. ``precision`` "bf16": the model's forward under bfloat16 autocast.
    ``fk_weight`` > 0 adds :func:`fk_loss` times it, ``contact_weight`` > 0 :func:`contact_loss` times it; both need
    ``norm`` = the features' ``(mean, std)``."""
    if (fk_weight > 0 or contact_weight > 0) and norm is None:
        raise ValueError("diffusion_loss: fk_weight or contact_weight > 0 needs norm=(mean, std)")
    if precision not in PRECISIONS:
        raise ValueError(f"diffusion_loss: expected precision in {PRECISIONS}, got {precision!r}")
    device = model_device(model)
    x0, valid, text, drop = x0.to(device), valid.to(device), text.to(device), drop.to(device)
    b = x0.shape[0]
    t = torch.randint(scheduler.num_train_steps, (b,), generator=generator).to(device)
    x_t = scheduler.add_noise(x0, torch.randn(x0.shape, generator=generator).to(device), t)
    with torch.autocast(device.type, dtype=torch.bfloat16, enabled=precision == "bf16"):
        pred = model(x_t, t, text, valid, drop=drop)
    rec, vel = x0_losses(pred.float(), x0, valid)
    loss, logs = rec + velocity_weight * vel, {"rec": rec.item(), "vel": vel.item()}
    if fk_weight > 0:
        fk = fk_loss(pred.float(), x0, valid, *norm)
        loss = loss + fk_weight * fk
        logs["fk"] = fk.item()
    if contact_weight > 0:
        contact = contact_loss(pred.float(), valid, *norm)
        loss = loss + contact_weight * contact
        logs["contact"] = contact.item()
    return loss, logs


def x0_losses(pred: torch.Tensor, x0: torch.Tensor, valid: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The prior's two loss terms on ``(B, T, D)`` over ``valid (B, T)``: x0 MSE and frame-difference MSE."""
    rec = masked_mse(pred, x0, valid)
    vel = masked_mse(pred[:, 1:] - pred[:, :-1], x0[:, 1:] - x0[:, :-1], valid[:, 1:] & valid[:, :-1])
    return rec, vel


class ValidationLoss:
    """The diffusion loss of a model on a fixed set of windows of a split, with fixed noise and steps spread
    evenly over the schedule, so values logged over a run (and across resumed runs) compare directly."""

    def __init__(self, data: MotionDataset, text: torch.Tensor, scheduler: DiffusionScheduler, n: int, window: int,
                 velocity_weight: float, seed: int = 12345, batch: int = 32):
        gen = torch.Generator().manual_seed(seed)
        self.x0, self.valid, idx = data.sample_windows(n, window, gen)
        self.text = text[idx]
        self.t = torch.linspace(0, scheduler.num_train_steps - 1, n).round().long()
        self.noise = torch.randn(self.x0.shape, generator=gen)
        self.scheduler, self.velocity_weight, self.batch = scheduler, velocity_weight, batch

    @torch.no_grad()
    def __call__(self, model) -> float:
        device = model_device(model)
        training = model.training
        model.eval()
        total, count = 0.0, 0
        for s in range(0, len(self.t), self.batch):
            sl = slice(s, s + self.batch)
            x0, valid, t = self.x0[sl].to(device), self.valid[sl].to(device), self.t[sl].to(device)
            x_t = self.scheduler.add_noise(x0, self.noise[sl].to(device), t)
            rec, vel = x0_losses(model(x_t, t, self.text[sl].to(device), valid), x0, valid)
            total += float(rec + self.velocity_weight * vel) * len(t)
            count += len(t)
        model.train(training)
        return total / count


def read_val_log(path: Path) -> list[tuple[int, float]]:
    """``[(step, val_loss), ...]`` from a run's ``val.csv`` (empty when there is none)."""
    path = Path(path)
    if not path.is_file():
        return []
    with open(path, newline="") as f:  # a resumed run may log a step again: the last value counts
        by_step = {int(r["step"]): float(r["val_loss"]) for r in csv.DictReader(f)}
    return sorted(by_step.items())


def convergence(val_log: list[tuple[int, float]], fraction: float = 0.2) -> float | None:
    """Relative fall of the validation loss over the last ``fraction`` of the steps (0.05 = fell 5 %), or
    None while there are too few values. The campaign's rule: converged when this is below 0.02."""
    if len(val_log) < 3:
        return None
    last_step, last = val_log[-1]
    start = last_step * (1 - fraction)
    before = [v for s, v in val_log if s <= start]
    if not before:
        return None
    return (before[-1] - last) / before[-1]


def train_prior(data_dir: Path, out_dir: Path, config: PriorTrainConfig, max_minutes: float, max_steps: int = 10**9,
                explicit: dict | None = None, progress: bool = True, device: str = "cpu") -> Trainer:
    """Train (or resume) the prior on ``device`` (:func:`mlcore.device.resolve_device`); the model starts
    from the same seeded weights on any device, batches and noise are drawn on the CPU."""
    device = resolve_device(device)
    out_dir = Path(out_dir)
    config = resumed_config(out_dir / "checkpoint.safetensors", config, explicit or {})
    torch.manual_seed(config.seed)
    data = MotionDataset(data_dir, "train", exclude_styles=tuple(config.exclude_styles))
    text = caption_embeddings(data).to(device)
    model = Denoiser(DenoiserConfig(width=config.width, layers=config.layers, heads=config.heads, ff=config.ff,
                                    dropout=config.dropout, derive_positions=config.derive_positions))
    model.set_normalization(data.mean, data.std).to(device)
    trainer = Trainer(model, config, out_dir, lr=config.lr, warmup=config.warmup, ema=config.ema,
                      decay=(config.decay_start, config.decay_steps, config.lr_final))
    trainer.resume(explicit or {})
    gen = torch.Generator().manual_seed(config.seed * 1000003 + trainer.step)
    scheduler = DiffusionScheduler(model.config.num_train_steps)
    evaluate = None
    if config.val_every > 0:
        val_data = MotionDataset(data_dir, "val", exclude_styles=tuple(config.exclude_styles))
        val_loss = ValidationLoss(val_data, caption_embeddings(val_data).to(device), scheduler, config.val_windows,
                                  config.window, config.velocity_weight)
        evaluate = _val_logger(val_loss, out_dir / "val.csv")

    def loss_fn(m, step):
        x0, valid, idx = data.sample_windows(config.batch_size, config.window, gen)
        drop = torch.rand(config.batch_size, generator=gen) < config.text_drop
        return diffusion_loss(m, scheduler, x0, valid, text[idx], drop, config.velocity_weight, gen, config.precision,
                              config.fk_weight, (data.mean, data.std), config.contact_weight)

    trainer.run(loss_fn, max_steps, max_minutes, progress=progress, evaluate=evaluate, eval_every=config.val_every or 1)
    export_prior(trainer, data, out_dir / "denoiser.safetensors", data_dir)
    return trainer


def _val_logger(val_loss: ValidationLoss, path: Path):
    """The trainer's ``evaluate`` callback: the EMA model's validation loss, appended to ``path`` (step, val_loss)."""
    def evaluate(ema, step: int) -> dict:
        value = val_loss(ema)
        new = not path.is_file()
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a", newline="") as f:
            if new:
                f.write("step,val_loss\n")
            f.write(f"{step},{value:.6f}\n")
        return {"val_loss": value}

    return evaluate


def export_prior(trainer: Trainer, data: MotionDataset, path: Path, data_dir: Path) -> None:
    """EMA weights + normalisation stats as safetensors, with a JSON model card."""
    card = {
        "model": "video2style motion diffusion prior (MDM-style transformer, predicts x0)",
        "data": f"Bandai-Namco-Research-Motiondataset-1 and -2 (train split of {Path(data_dir).name}), mirrored, 20 fps"
                + (f"; every clip of the styles {', '.join(trainer.config.exclude_styles)} left out (clips and captions; "
                   "the feature mean/std are the whole train split's)" if trainer.config.exclude_styles else ""),
        "validation_loss": read_val_log(Path(trainer.out_dir) / "val.csv")[-1:] or None,
        "licence": "CC BY-NC 4.0, inherited from the Bandai-Namco training data",
        "steps": trainer.step,
        "wall_time_minutes": round(trainer.elapsed / 60, 1),
        "train_config": asdict(trainer.config),
        "model_config": asdict(trainer.model.config),
        "machine": "2 CPU cores",
        "date": time.strftime("%Y-%m-%d"),
    }
    save_model(trainer.ema, trainer.model.config, path, card, extra={"norm.mean": data.mean, "norm.std": data.std})


def load_prior(path: Path) -> tuple[Denoiser, torch.Tensor, torch.Tensor]:
    """Denoiser (EMA weights) and the feature mean/std it was trained with."""
    model, extra = load_denoiser(path)
    return model, extra["norm.mean"], extra["norm.std"]
