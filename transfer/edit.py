"""Editing a motion by noise (Hu et al. 2024 §3.2, §3.5): noise normalised features some steps and denoise them
keeping the root's path on the ground (:data:`TRAJECTORY`, inpainted at every step). :func:`neutralize` redraws
motions with the prior under a neutral caption (the style example's pair, a styled content clip); :func:`stylize`
redraws content with a style model (alone, guided, or as its difference from the prior)."""
from __future__ import annotations

import torch

from motioncore.representation import FEATURES
from transfer.sampling import denoise, noise_keeping
from transfer.scheduler import DiffusionScheduler
from transfer.style_config import ApplyConfig, LearnConfig

TRAJECTORY = [FEATURES.root_rvel, FEATURES.root_lvel]  # inpainted: the root's path on the ground


def neutralize(prior, scheduler: DiffusionScheduler, x: torch.Tensor, text: torch.Tensor, config: LearnConfig,
               generator: torch.Generator, step: int | None = None) -> torch.Tensor:
    """Neutral version ``(B, T, D)`` of normalised motions ``x (B, T, D)``, same path, text ``(B, E)``;
    noised to ``step`` (default G, ``config.pair_noise_step``) and denoised with the text. ``x`` and ``text`` are on
    the prior's device; the noise is drawn on the CPU from ``generator`` and moved there."""
    g = config.pair_noise_step if step is None else step
    n_steps = max(1, round(config.pair_ddim_steps * g / config.pair_noise_step))
    noise = torch.randn(x.shape, generator=generator).to(x.device)
    x_g = noise_keeping(scheduler, x, noise, g, TRAJECTORY)
    return denoise(prior, scheduler, x_g, g, n_steps, text, guidance=config.guidance,
                   inpaint=(x, TRAJECTORY), generator=generator)


class StyleGuided(torch.nn.Module):
    """``x0 = prior + w * (style - prior)``: style guidance at sampling (``w = 1``: the style model alone)."""

    def __init__(self, prior, style, weight: float):
        super().__init__()
        self.prior, self.style, self.weight = prior, style, weight
        self.config = style.config

    def forward(self, x_t, t, text=None, valid=None):
        x0_style = self.style(x_t, t, text, valid)
        if self.weight == 1.0:
            return x0_style
        x0_prior = self.prior(x_t, t, text, valid)
        return x0_prior + self.weight * (x0_style - x0_prior)


def stylize(model, scheduler: DiffusionScheduler, x: torch.Tensor, learned: LearnConfig, config: ApplyConfig,
            generator: torch.Generator, step: int | None = None, prior=None, shares: list | None = None) -> torch.Tensor:
    """Apply the style model to normalised content ``x (B, T, D)``: noise it K steps (default the style's
    ``learned.transfer_noise_step``), denoise keeping its path, at the style's density of DDIM steps (``learned.transfer_ddim_steps``
    per ``learned.transfer_noise_step``). Returns ``(B, T, D)``.

    ``config.apply_mode`` "difference" (needs ``prior``): ``x + scale * (style(y) - prior(y))`` from the same
    noisy ``y``; "regenerate": the style model's own result, guided with weight ``scale`` when a prior is given.
    ``scale`` is ``config.style_scale`` (see :func:`transfer.style_config.strength_settings`). With
    ``config.still_guard`` the difference keeps its fast part only where the style model moves
    (:func:`keep_slow_when_still`); each window's share of it is appended to ``shares`` when a list is given. ``x`` is
    on the models' device; the noise is drawn on the CPU from ``generator`` and moved there.
    """
    k = learned.transfer_noise_step if step is None else step
    scale = config.style_scale
    noise = torch.randn(x.shape, generator=generator).to(x.device)
    y = noise_keeping(scheduler, x, noise, k, TRAJECTORY)
    n_steps = max(1, round(learned.transfer_ddim_steps * k / learned.transfer_noise_step))
    if config.apply_mode == "difference":
        if prior is None:
            raise ValueError("stylize: the difference mode needs the prior")
        if config.guided_difference:
            styled = denoise(StyleGuided(prior, model, scale), scheduler, y, k, n_steps, None, inpaint=(x, TRAJECTORY))
            scale = 1.0
        else:
            styled = denoise(model, scheduler, y, k, n_steps, None, inpaint=(x, TRAJECTORY))
        base = denoise(prior, scheduler, y, k, n_steps, None, inpaint=(x, TRAJECTORY))
        delta = smooth_time(styled - base, config.delta_smoothing)
        if config.still_guard:
            delta = keep_slow_when_still(delta, styled, base, shares)
        return x + scale * delta
    if config.apply_mode != "regenerate":
        raise ValueError(f"stylize: expected apply_mode 'regenerate' or 'difference', got {config.apply_mode!r}")
    if prior is not None and scale != 1.0:
        model = StyleGuided(prior, model, scale)
    return denoise(model, scheduler, y, k, n_steps, None, inpaint=(x, TRAJECTORY))


# A style model can collapse onto a still pose: learned from an example whose neutral pair steps out of time with it
# (seen with videos' examples), it redraws any content nearly without movement, and its difference from the prior
# then cancels the content's own steps (feet that no longer lift, then slide). Measured by how much the style
# model's result moves against the prior's (temporal standard deviation over the window, mean over channels):
# at STILL_RATIO[0] or below only the slow part of the difference is kept (Gaussian, STILL_SMOOTHING frames), at
# STILL_RATIO[1] or above all of it, eased between. Styles learned from the dataset's clips move 0.96-1.33 x as much
# as the prior; the demo's elderly example's 0.21 x
# (docs/archive/RESULTS-notebook.md#a-style-models-still-pose-the-demos-feet-issue-23-item-5-issue-24s-walks-shuffle).
STILL_RATIO = (0.4, 0.7)
STILL_SMOOTHING = 4.0


def still_share(styled: torch.Tensor, base: torch.Tensor) -> torch.Tensor:
    """``(B,)`` in [0, 1]: how much of the style's difference keeps its fast part, from the style model's result
    ``styled (B, T, D)`` and the prior's ``base (B, T, D)`` on the same noisy content (see :data:`STILL_RATIO`)."""
    if styled.shape != base.shape or styled.ndim != 3:
        raise ValueError(f"still_share: expected styled and base (B, T, D) alike, got {tuple(styled.shape)} and "
                         f"{tuple(base.shape)}")
    if styled.shape[1] < 2:
        return torch.ones(styled.shape[0], device=styled.device)
    ratio = styled.std(1).mean(-1) / base.std(1).mean(-1).clamp_min(1e-6)
    lo, hi = STILL_RATIO
    w = ((ratio - lo) / (hi - lo)).clamp(0, 1)
    return w * w * (3 - 2 * w)


def keep_slow_when_still(delta: torch.Tensor, styled: torch.Tensor, base: torch.Tensor,
                         shares: list | None = None) -> torch.Tensor:
    """The style's difference ``delta (B, T, D)`` with its fast part kept only as far as :func:`still_share` says
    (appended to ``shares``, one float per window, when a list is given)."""
    w = still_share(styled, base)
    if shares is not None:
        shares.extend(w.tolist())
    w = w[:, None, None].to(delta)
    slow = smooth_time(delta, STILL_SMOOTHING)
    return torch.where(w >= 1, delta, slow + w * (delta - slow))  # no host sync: any device


def smooth_time(x: torch.Tensor, sigma: float) -> torch.Tensor:
    """Gaussian low-pass of ``x (B, T, D)`` along T with ``sigma`` frames (edges replicated); 0 = unchanged."""
    if sigma <= 0:
        return x
    radius = max(1, int(3 * sigma))
    k = torch.exp(-0.5 * (torch.arange(-radius, radius + 1, dtype=x.dtype, device=x.device) / sigma) ** 2)
    k = (k / k.sum()).expand(x.shape[-1], 1, -1)
    padded = torch.nn.functional.pad(x.transpose(1, 2), (radius, radius), mode="replicate")
    return torch.nn.functional.conv1d(padded, k, groups=x.shape[-1]).transpose(1, 2)
