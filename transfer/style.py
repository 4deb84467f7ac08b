"""On-the-fly style learning after Hu et al. 2024 §3.2-3.5.

1. ``neutralize``: noise the style example to step G and denoise it with the prior conditioned
   on the neutral caption, inpainting the example's root trajectory at every step (eq. 3-5).
2. ``learn_style``: a copy of the prior with LoRA adapters learns to turn the neutral pair,
   noised K steps, into the example (L_rec, eq. 10), while content clips from the dataset,
   passed through the style model, must match their captions with the style words added in the
   motion encoder's text space (L_s, eq. 11). Only the adapters train.
3. The result is a :class:`Style`: adapter tensors in safetensors plus JSON metadata.
"""
from __future__ import annotations

import copy
import hashlib
import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import load_file, save_file

from motioncore.representation import FEATURES
from transfer.captions import caption
from transfer.lora import add_lora, load_lora_state, lora_state, set_strength
from transfer.sampling import denoise, overwrite
from transfer.scheduler import DiffusionScheduler

TRAJECTORY = [FEATURES.root_rvel, FEATURES.root_lvel]  # inpainted: the root's path on the ground


@dataclass
class StyleConfig:
    pair_step: int = 950  # G
    pair_steps: int = 30  # DDIM steps from G to 0 for the neutral pair
    guidance: float = 2.5
    transfer_step: int = 300  # K
    transfer_steps: int = 6  # DDIM steps from K to 0 (K = 300 with 20 steps over 1000)
    rank: int = 8
    lr: float = 2e-3
    iterations: int = 150
    max_seconds: float = 60.0
    lambda_s: float = 0.1
    content_batch: int = 8
    window: int = 80
    seed: int = 0
    pair_generation: bool = True  # False (ablation): fine-tune from the example itself instead of its neutral pair
    lambda_p: float = 0.2  # prior preservation on the content batch (not in Hu et al.; 0 = the paper; see docs/RESULTS.md)


@dataclass
class Style:
    """A learned style: adapter tensors and what is needed to apply them."""

    adapters: dict[str, torch.Tensor]
    meta: dict = field(default_factory=dict)
    example: torch.Tensor | None = None  # the style example, canonical features (T, D), for previews

    def save(self, path: Path) -> None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tensors = {k: v.to(torch.float16).contiguous() for k, v in self.adapters.items()}
        if self.example is not None:
            tensors["example"] = self.example.float().contiguous()
        try:
            save_file(tensors, str(tmp), metadata={"video2style": json.dumps(self.meta)})
            tmp.replace(path)
        finally:
            tmp.unlink(missing_ok=True)

    @staticmethod
    def load(path: Path) -> Style:
        path = Path(path)
        try:
            with safe_open(str(path), framework="pt") as f:
                meta = json.loads((f.metadata() or {})["video2style"])
            tensors = load_file(str(path))
        except FileNotFoundError:
            raise FileNotFoundError(f"{path}: no such style file") from None
        except Exception as e:  # noqa: BLE001 - safetensors raises its own errors on garbage
            raise ValueError(f"{path}: not a video2style style file ({e})") from None
        example = tensors.pop("example", None)
        return Style({k: v.float() for k, v in tensors.items()}, meta, example)


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def neutralize(prior, scheduler: DiffusionScheduler, x: torch.Tensor, text: torch.Tensor, config: StyleConfig,
               generator: torch.Generator) -> torch.Tensor:
    """Neutral version ``(B, T, D)`` of normalised motions ``x (B, T, D)``, same path, text ``(B, E)``."""
    noise = torch.randn(x.shape, generator=generator)
    x_g = overwrite(scheduler.add_noise(x, noise, config.pair_step), x * scheduler.alphas_cumprod[config.pair_step].sqrt(), TRAJECTORY)
    return denoise(prior, scheduler, x_g, config.pair_step, config.pair_steps, text, guidance=config.guidance,
                   inpaint=(x, TRAJECTORY), generator=generator)


def stylize(model, scheduler: DiffusionScheduler, x: torch.Tensor, config: StyleConfig, generator: torch.Generator,
            step: int | None = None) -> torch.Tensor:
    """Apply the style model: noise normalised content ``x (B, T, D)`` K steps, denoise keeping its path."""
    k = config.transfer_step if step is None else step
    noise = torch.randn(x.shape, generator=generator)
    y = overwrite(scheduler.add_noise(x, noise, k), x * scheduler.alphas_cumprod[k].sqrt(), TRAJECTORY)
    n_steps = max(1, round(config.transfer_steps * k / config.transfer_step))
    return denoise(model, scheduler, y, k, n_steps, None, inpaint=(x, TRAJECTORY))


def _windows(n: int, window: int, count: int, generator: torch.Generator) -> list[int]:
    if n <= window:
        return [0] * count
    return torch.randint(n - window + 1, (count,), generator=generator).tolist()


def learn_style(prior, motion_encoder, text_encoder, dataset, example: torch.Tensor, style_words: str, content: str,
                config: StyleConfig, prior_path: Path | None = None, progress=None) -> tuple[Style, dict]:
    """Learn a style from one normalised example ``(T, D)`` whose content is ``content`` (a Bandai content name
    or free text). ``dataset``: the prior's training cache (content motions for L_s). Returns the style and stats.
    """
    if example.ndim != 2 or example.shape[1] != FEATURES.dim:
        raise ValueError(f"learn_style: expected an example (T, {FEATURES.dim}), got {tuple(example.shape)}")
    t0 = time.time()
    gen = torch.Generator().manual_seed(config.seed)
    torch.manual_seed(config.seed)
    scheduler = DiffusionScheduler(prior.config.num_train_steps)
    neutral_text = content if content.startswith("a person") else caption(content, None)
    say = progress or (lambda msg: None)

    if config.pair_generation:
        say("generating the style-neutral pair")
        with torch.no_grad():
            pair = neutralize(prior, scheduler, example[None], text_encoder.encode([neutral_text]), config, gen)[0]
    else:
        pair = example.clone()

    say("fine-tuning the style model")
    model = copy.deepcopy(prior)
    add_lora(model, rank=config.rank)
    model.train()
    params = [p for p in model.parameters() if p.requires_grad]
    opt = torch.optim.Adam(params, lr=config.lr)
    neutral = [i for i, r in enumerate(dataset.records) if r.style == "normal"]
    if not neutral:
        raise ValueError("learn_style: the dataset has no neutral ('normal') clips for the semantic loss")
    target_captions = sorted({dataset.records[i].caption for i in neutral})
    styled = {c: f"{c}, {style_words} style" for c in target_captions}
    target_emb = dict(zip(target_captions, text_encoder.encode([styled[c] for c in target_captions])))
    history = []
    it = 0
    while it < config.iterations and time.time() - t0 < config.max_seconds:
        # L_rec: the neutral pair noised K steps must denoise to the example at every step (eq. 10)
        s = _windows(example.shape[0], config.window, 1, gen)[0]
        m_s, m_n = example[None, s:s + config.window], pair[None, s:s + config.window]
        y = overwrite(scheduler.add_noise(m_n, torch.randn(m_n.shape, generator=gen), config.transfer_step),
                      m_n * scheduler.alphas_cumprod[config.transfer_step].sqrt(), TRAJECTORY)
        loss_rec = 0.0
        steps = scheduler.set_timesteps(config.transfer_steps, config.transfer_step).tolist()
        for t in steps:
            x0 = model(y, torch.tensor([t]))
            x0 = overwrite(x0, m_s, TRAJECTORY)
            loss_rec = loss_rec + ((x0 - m_s) ** 2).mean() / len(steps)
            y = scheduler.step(x0.detach(), t, y)
        # L_s: neutral content motions, stylised, must read as "<caption>, <style> style" (eq. 11)
        idx = [neutral[i] for i in torch.randint(len(neutral), (config.content_batch,), generator=gen).tolist()]
        xs = torch.stack([_crop(dataset.clip(i), config.window, gen) for i in idx])
        valid = torch.stack([_crop_mask(dataset.records[i].length, config.window) for i in idx])
        t = steps[int(torch.randint(len(steps), (1,), generator=gen))]
        y_c = overwrite(scheduler.add_noise(xs, torch.randn(xs.shape, generator=gen), t), xs * scheduler.alphas_cumprod[t].sqrt(), TRAJECTORY)
        x0_c = overwrite(model(y_c, torch.full((len(idx),), t), None, valid), xs, TRAJECTORY)
        z = motion_encoder(x0_c * valid[..., None], valid)
        target = torch.stack([target_emb[dataset.records[i].caption] for i in idx])
        loss_s = (1 - (z * target).sum(-1)).mean()
        loss = loss_rec + config.lambda_s * loss_s
        if config.lambda_p > 0:  # the style model's x0 on content should stay near the prior's
            with torch.no_grad():
                x0_p = overwrite(prior(y_c, torch.full((len(idx),), t), None, valid), xs, TRAJECTORY)
            w = valid[..., None].to(x0_c.dtype)
            loss = loss + config.lambda_p * (((x0_c - x0_p) ** 2) * w).sum() / (w.sum() * x0_c.shape[-1])
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        it += 1
        history.append((loss_rec.item(), loss_s.item()))
        if it % 10 == 0:
            say(f"fine-tuning: iteration {it}, L_rec {loss_rec.item():.4f}, L_s {loss_s.item():.4f}")
    model.eval()
    meta = {
        "style": style_words,
        "content": neutral_text,
        "config": asdict(config),
        "iterations": it,
        "seconds": round(time.time() - t0, 1),
        "example_frames": int(example.shape[0]),
        "loss_rec_first_last": [history[0][0], history[-1][0]] if history else None,
        "loss_s_first_last": [history[0][1], history[-1][1]] if history else None,
        "base_model_sha256": file_sha256(prior_path) if prior_path else None,
        "rank": config.rank,
    }
    return Style(lora_state(model), meta), {"pair": pair, "history": history}


def _crop(x: torch.Tensor, window: int, gen: torch.Generator) -> torch.Tensor:
    out = torch.zeros(window, x.shape[1])
    s = _windows(x.shape[0], window, 1, gen)[0]
    part = x[s:s + window]
    out[: part.shape[0]] = part
    return out


def _crop_mask(length: int, window: int) -> torch.Tensor:
    valid = torch.zeros(window, dtype=torch.bool)
    valid[: min(length, window)] = True
    return valid


def style_model(prior, style: Style, strength: float = 1.0):
    """A copy of the prior with the style's adapters loaded (eval mode)."""
    rank = int(style.meta.get("rank", 8))
    model = copy.deepcopy(prior)
    add_lora(model, rank=rank)
    load_lora_state(model, style.adapters)
    set_strength(model, strength)
    return model.eval()
