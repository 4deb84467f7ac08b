"""Learning a style on the fly, after Hu et al. 2024 §3.2-3.5.

1. The neutral pair: the style example noised to step G and denoised by the prior under the neutral caption,
   its root trajectory inpainted at every step (eq. 3-5; :func:`transfer.edit.neutralize`), in windows as long as
   the prior's training windows when the example is longer.
   Each body channel's time-mean is then held where the example or the content source's neutral clips of its
   action hold it (:func:`transfer.posture.bound_pair`): a tilt the prior drew is not learned as the style's.
2. :func:`learn_style`: a copy of the prior with LoRA adapters learns to turn the neutral pair, noised K steps,
   into the example (L_rec, eq. 10, :func:`reconstruction_loss`), while content clips from the dataset, passed
   through the style model, change in the motion encoder's space as the example differs from its pair and stay
   near the prior's (the word-free signals, :mod:`transfer.style_losses`). Only the adapters train.
3. The result is a :class:`transfer.style_file.Style`: adapter tensors plus JSON metadata.
"""
from __future__ import annotations

import copy
import itertools
import time

import torch
from torch.profiler import record_function
from tqdm import tqdm

from mlcore.captions import caption
from mlcore.device import model_device
from motioncore.representation import FEATURES
from transfer.amount import calibrate_gain, calibration_clips, style_distance
from transfer.apply import apply_style_features, neutralize_windows
from transfer.edit import TRAJECTORY, neutralize
from transfer.lora import add_lora, lora_state
from transfer.posture import bound_pair
from transfer.sampling import denoising_steps, noise_keeping, overwrite
from transfer.scheduler import DiffusionScheduler
from transfer.style_config import MIN_ITERATIONS, ApplyConfig, LearnConfig, config_dict
from transfer.style_file import Style
from transfer.style_losses import (
    directional_loss,
    neutral_shift,
    posture_shift,
    statistics_direction_loss,
    statistics_loss,
    style_shift,
)


def _random_window_starts(n: int, window: int, count: int, generator: torch.Generator) -> list[int]:
    """``count`` random starts of ``window``-frame windows in ``n`` frames (all 0 when the clip is no longer)."""
    if n <= window:
        return [0] * count
    return torch.randint(n - window + 1, (count,), generator=generator).tolist()


def learn_style(bundle, dataset, example: torch.Tensor, style_words: str, content_text: str, config: LearnConfig,
                progress=None, show_bar: bool = False, apply: ApplyConfig | None = None) -> tuple[Style, dict]:
    """Learn a style on the prior of ``bundle`` (:class:`transfer.bundle.MethodBundle`: its prior, scheduler, motion
    and text encoders) from one normalised example
    ``(T, D)`` whose content is ``content_text`` (a Bandai content label or a caption). ``dataset``: the prior's training
    cache (content motions for the content losses). Returns the style and stats (``pair (T, D)``, ``history``).

    The budget is ``config.iterations``; with the same seed the adapters are the same on any machine, however
    busy. ``config.max_seconds`` (optional) caps the wall time; when it cuts learning short, ``meta["stopped_by"]``
    is ``"time"`` (see :func:`partial_reason`). ``show_bar``: a tqdm bar of iterations with an ETA. ``apply``: the
    apply settings the style file records beside ``config`` (default: today's, :class:`ApplyConfig`).

    Learning runs on the prior's device (the bundle's motion encoder is on it too); random numbers come from a
    seeded CPU generator, so the noise is the same on any device. The style's tensors are on the CPU.
    """
    if example.ndim != 2 or example.shape[1] != FEATURES.dim:
        raise ValueError(f"learn_style: expected an example (T, {FEATURES.dim}), got {tuple(example.shape)}")
    t0 = time.time()
    prior, motion_encoder, text_encoder, scheduler = bundle.prior, bundle.motion_encoder, bundle.text_encoder, bundle.scheduler
    device = model_device(prior)
    example = example.to(device)
    gen = torch.Generator().manual_seed(config.seed)
    torch.manual_seed(config.seed)
    neutral_text = content_text if content_text.startswith("a person") else caption(content_text, None)
    say = progress or (lambda msg: None)

    if config.pair_generation:
        say("generating the style-neutral pair")
        pair = _pair(bundle, dataset, example, neutral_text, config, gen)
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
    target_emb = {}
    if config.lambda_s > 0:  # the words' text target; with lambda_s 0 the words never enter learning
        target_captions = sorted({dataset.records[i].caption for i in neutral})
        styled = [f"{c}, {style_words} style" for c in target_captions]
        target_emb = dict(zip(target_captions, text_encoder.encode(styled).to(device)))
    shift = None
    if config.lambda_stat > 0 or config.lambda_stat_dir > 0:
        same = [i for i in neutral if dataset.records[i].caption == neutral_text] if config.stat_reference == "neutral" else []
        if config.stat_reference not in ("pair", "neutral"):
            raise ValueError(f"learn_style: expected stat_reference 'pair' or 'neutral', got {config.stat_reference!r}")
        shift = style_shift(example, pair) if not same else neutral_shift(example, [dataset.clip(i) for i in same])
    if config.lambda_dir > 0:
        with torch.no_grad():
            z_ex, z_pair = motion_encoder(torch.stack([example, pair]))
        direction = z_ex - z_pair
    steps = scheduler.set_timesteps(config.transfer_ddim_steps, config.transfer_noise_step).tolist()
    history = []
    it, stopped_by = 0, "iterations"
    bar = tqdm(total=config.iterations, desc="      fine-tuning", unit="it", disable=not show_bar, leave=False)
    while it < config.iterations:
        if config.max_seconds is not None and time.time() - t0 >= config.max_seconds:
            stopped_by = "time"
            break
        with record_function("learn: L_rec"):
            starts = _random_window_starts(example.shape[0], config.window, config.rec_windows, gen)
            loss_rec = reconstruction_loss(model, scheduler, torch.stack([pair[s:s + config.window] for s in starts]),
                                           torch.stack([example[s:s + config.window] for s in starts]), config, gen)
        with record_function("learn: L_s"):  # neutral content, stylised, must read as "<caption>, <style> style" (eq. 11)
            idx = [neutral[i] for i in torch.randint(len(neutral), (config.content_batch,), generator=gen).tolist()]
            xs = torch.stack([_crop(dataset.clip(i), config.window, gen) for i in idx]).to(device)
            valid = torch.stack([_crop_mask(dataset.records[i].length, config.window) for i in idx]).to(device)
            t = steps[int(torch.randint(len(steps), (1,), generator=gen))]
            y_c = noise_keeping(scheduler, xs, torch.randn(xs.shape, generator=gen).to(device), t, TRAJECTORY)
            x0_c = overwrite(model(y_c, torch.full((len(idx),), t, device=device), None, valid), xs, TRAJECTORY)
            loss = loss_rec
            loss_s = torch.zeros(())
            if config.lambda_s > 0 or config.lambda_dir > 0:
                z = motion_encoder(x0_c * valid[..., None], valid)
            if config.lambda_s > 0:
                target = torch.stack([target_emb[dataset.records[i].caption] for i in idx])
                loss_s = (1 - (z * target).sum(-1)).mean()
                loss = loss + config.lambda_s * loss_s
        if config.lambda_p > 0 or shift is not None or config.lambda_dir > 0:
            with record_function("learn: the prior on content"), torch.no_grad():
                x0_p = overwrite(prior(y_c, torch.full((len(idx),), t, device=device), None, valid), xs, TRAJECTORY)
        if config.lambda_p > 0:  # the style model's x0 on content should stay near the prior's
            w = valid[..., None].to(x0_c.dtype)
            loss = loss + config.lambda_p * (((x0_c - x0_p) ** 2) * w).sum() / (w.sum() * x0_c.shape[-1])
        if config.lambda_stat > 0:  # word-free: shift the content's statistics as the example shifts its pair's
            loss = loss + config.lambda_stat * statistics_loss(x0_c, x0_p, valid, shift, config.stat_std)
        if config.lambda_stat_dir > 0:  # word-free: ... or at least point their change the same way
            loss = loss + config.lambda_stat_dir * statistics_direction_loss(x0_c, x0_p, valid, shift)
        if config.lambda_dir > 0:  # word-free: the change points the example's way in the encoder's space
            with torch.no_grad():
                z_p = motion_encoder(x0_p * valid[..., None], valid)
            loss = loss + config.lambda_dir * directional_loss(z, z_p, direction)
        with record_function("learn: backward + step"):
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        it += 1
        history.append((loss_rec.item(), loss_s.item()))
        bar.update(1)
        bar.set_postfix(L_rec=f"{history[-1][0]:.4f}", L_s=f"{history[-1][1]:.4f}")
    bar.close()
    model.eval()
    meta = {
        "style": style_words,
        "content": neutral_text,
        "config": config_dict(config, apply or ApplyConfig()),
        "iterations": it,
        "iterations_planned": config.iterations,
        "stopped_by": stopped_by,
        "seconds": round(time.time() - t0, 1),
        "example_frames": int(example.shape[0]),
        "loss_rec": [float(f"{h[0]:.5g}") for h in history],
        "loss_s": [float(f"{h[1]:.5g}") for h in history],
        "base_model_sha256": None,  # the prior's file, recorded where a style is learned from a file to be shared
        "rank": config.rank,
    }
    posture = posture_shift(example, pair).cpu()  # where the example holds each joint, against its pair
    style = Style(lora_state(model), meta, posture_shift=posture)
    if config.calibrate:
        say("measuring how strongly the style shows")
        meta["amount"] = _calibrate(bundle, model, style, dataset, example, pair, config, apply or ApplyConfig())
    return style, {"pair": pair.cpu(), "history": history}


def _calibrate(bundle, model, style: Style, dataset, example: torch.Tensor, pair: torch.Tensor, config: LearnConfig,
               apply: ApplyConfig) -> dict:
    """The style's calibrated amount (:func:`transfer.amount.calibrate_gain`): the example's distance from its pair,
    and the gain that moves neutral clips of other actions as far at ``--strength 0.5``."""
    raw_example = bundle.denormalize(example.cpu()) if bundle.mean is not None else None
    device = model_device(model)

    def at_gain_one(clip: torch.Tensor) -> torch.Tensor:
        return apply_style_features(bundle, model, clip.to(device), config, apply, 0.5, config.seed,
                                    posture_shift=style.posture_shift, example=raw_example).cpu()

    target = style_distance(example.cpu(), pair.cpu())
    gain, reached = calibrate_gain(at_gain_one, target, calibration_clips(dataset))
    return {"gain": round(gain, 4), "target": round(target, 4), "reached": round(reached, 4)}


@torch.no_grad()
def _pair(bundle, dataset, example: torch.Tensor, neutral_text: str, config: LearnConfig,
          gen: torch.Generator) -> torch.Tensor:
    """The neutral pair ``(T, D)`` of ``example (T, D)``, drawn by the prior (with ``config.pair_windowed``, in
    ``config.window``-frame windows, :func:`transfer.apply.neutralize_windows`) and, with
    ``config.pair_between``, held where ``dataset``'s neutral clips of ``neutral_text`` hold the body (:func:`transfer.posture.bound_pair`)."""
    text = bundle.text_encoder.encode([neutral_text]).to(example.device)
    if config.pair_windowed:
        pair = neutralize_windows(bundle.prior, bundle.scheduler, example, text, config, gen, window=config.window)
    else:
        pair = neutralize(bundle.prior, bundle.scheduler, example[None], text, config, gen)[0]
    if config.pair_between:
        pair = bound_pair(pair, example, _neutral_clips(dataset, neutral_text, example.device))
    return pair


def _neutral_clips(dataset, text: str, device) -> list[torch.Tensor]:
    """The neutral ('normal') clips of ``dataset`` whose caption is ``text``, normalised ``(T_i, D)``."""
    return [dataset.clip(i).to(device) for i, r in enumerate(dataset.records) if r.style == "normal" and r.caption == text]


def neutral_pair(bundle, example: torch.Tensor, config: LearnConfig, content_text: str | None = None,
                 dataset=None) -> torch.Tensor:
    """The style-neutral pair ``(T, D)`` of a normalised ``example (T, D)`` exactly as :func:`learn_style` draws it
    with ``config`` (its seed): ``content_text`` as learning is given it (default: what the motion encoder reads);
    ``dataset``: the content source learning is given (needed when ``config.pair_between``)."""
    from transfer.apply import read_motion

    if content_text is None:
        content_text = read_motion(bundle.motion_encoder, bundle.text_encoder, example).content
    neutral_text = content_text if content_text.startswith("a person") else caption(content_text, None)
    device = model_device(bundle.prior)
    if config.pair_between and dataset is None:
        raise ValueError("neutral_pair: expected the content source (dataset) with config.pair_between")
    torch.manual_seed(config.seed)
    return _pair(bundle, dataset, example.to(device), neutral_text, config, torch.Generator().manual_seed(config.seed)).cpu()


def partial_reason(meta: dict, min_iterations: int = MIN_ITERATIONS) -> str | None:
    """Why a learned style is not a complete one (a one-line reason), or None when it is."""
    done, planned = int(meta.get("iterations", 0)), int(meta.get("iterations_planned", meta.get("iterations", 0)))
    if meta.get("stopped_by") == "time":
        cap = meta.get("config", {}).get("max_seconds")
        return (f"learning was cut short by the time cap ({cap:g} s) after {done} of {planned} iterations"
                + (f", fewer than the {min_iterations} a style needs to keep the content" if done < min_iterations else ""))
    if done < min_iterations:
        return f"only {done} fine-tuning iterations, fewer than the {min_iterations} a style needs to keep the content"
    return None


def reconstruction_loss(model, scheduler: DiffusionScheduler, m_n: torch.Tensor, m_s: torch.Tensor, config: LearnConfig,
                        generator: torch.Generator) -> torch.Tensor:
    """L_rec (Hu et al. eq. 10): the neutral windows ``m_n (B, L, D)`` noised K steps must denoise to the example
    windows ``m_s (B, L, D)`` at every DDIM step from K to 0. Both on the model's device, with the same root path
    (the pair is made on the example's path): the unroll inpaints the example's.

    Each step's input depends on the previous prediction only through a detached value, so the unroll
    (:func:`transfer.sampling.denoising_steps`) runs without gradients (and without dropout) and the model then
    sees all the steps' inputs in one batched pass.
    """
    if m_n.ndim != 3 or m_n.shape != m_s.shape:
        raise ValueError(f"reconstruction_loss: expected m_n and m_s (B, L, D) alike, got {tuple(m_n.shape)} and {tuple(m_s.shape)}")
    k = config.transfer_noise_step
    steps = scheduler.set_timesteps(config.transfer_ddim_steps, k).tolist()
    y = noise_keeping(scheduler, m_n, torch.randn(m_n.shape, generator=generator).to(m_n.device), k, TRAJECTORY)
    training = model.training
    model.eval()
    with torch.no_grad():  # the inputs of the steps only: the last step's prediction is never made
        unroll = denoising_steps(model, scheduler, y, k, config.transfer_ddim_steps, inpaint=(m_s, TRAJECTORY))
        inputs = [x_t for _, x_t in itertools.islice(unroll, len(steps))]
    model.train(training)
    target = m_s.repeat(len(steps), 1, 1)  # torch.cat(inputs) is step-major: B windows per step
    t = torch.tensor(steps, device=m_s.device).repeat_interleave(m_s.shape[0])
    x0 = overwrite(model(torch.cat(inputs), t), target, TRAJECTORY)
    return ((x0 - target) ** 2).mean()


def _crop(x: torch.Tensor, window: int, gen: torch.Generator) -> torch.Tensor:
    out = torch.zeros(window, x.shape[1])
    s = _random_window_starts(x.shape[0], window, 1, gen)[0]
    part = x[s:s + window]
    out[: part.shape[0]] = part
    return out


def _crop_mask(length: int, window: int) -> torch.Tensor:
    valid = torch.zeros(window, dtype=torch.bool)
    valid[: min(length, window)] = True
    return valid
