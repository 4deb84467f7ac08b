"""Sampling loops over a denoiser and a scheduler: text-to-motion, and editing from a given step."""
from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import torch

from mlcore.device import model_device
from transfer.scheduler import DiffusionScheduler


def predict_x0(model, x_t, t, text=None, valid=None, guidance: float = 1.0):
    """Classifier-free guided x0 prediction; ``guidance=1`` is the plain conditional model."""
    cond = model(x_t, t, text, valid)
    if text is None or guidance == 1.0:
        return cond
    uncond = model(x_t, t, None, valid)
    return uncond + guidance * (cond - uncond)


Guide = Callable[[torch.Tensor], torch.Tensor]  # an x0 prediction (B, T, D) -> a corrected one, same shape


@dataclass(frozen=True)
class TextToMotion:
    """How motion is drawn from text alone: the content bank, the demo's sample clips, the prior's benchmarks.
    (Style learning's neutral pair is an edit with its own settings, :class:`transfer.style_config.LearnConfig`.)
    Chosen in docs/archive/RESULTS-notebook.md#planted-feet-at-sampling-issue-24.

    ``contact_rate``, ``contact_iterations``: each x0 prediction takes that many gradient steps of that size down
    the planted feet's travel (:func:`transfer.prior.contact_guide`); 0 turns it off.
    ``derive_positions``: then each x0 prediction's joint-position channels are replaced by the joints its rotation
    channels place (:func:`transfer.denoiser.derive_position_channels`), so the two channel sets of a draw agree
    (chosen in docs/archive/RESULTS-notebook.md#position-channels-derived-at-sampling-shipped).
    """

    steps: int = 50  # DDIM steps
    guidance: float = 2.0  # classifier-free guidance scale
    contact_rate: float = 0.02
    contact_iterations: int = 2
    derive_positions: bool = True

    def __post_init__(self):
        for name, value, low in (("steps", self.steps, 1), ("guidance", self.guidance, 0.0),
                                 ("contact_rate", self.contact_rate, 0.0), ("contact_iterations", self.contact_iterations, 0)):
            if value < low:
                raise ValueError(f"TextToMotion: expected {name} >= {low}, got {value}")

    @staticmethod
    def add_options(parser) -> None:
        """``--steps``, ``--guidance``, ``--contact-rate``, ``--contact-iterations``, ``--[no-]derive-positions`` on an argparse ``parser``,
        defaulting to the project's settings (:data:`TEXT_TO_MOTION`); :meth:`from_options` reads them back."""
        d = TEXT_TO_MOTION
        parser.add_argument("--steps", type=int, default=d.steps, help=f"DDIM steps (default: {d.steps})")
        parser.add_argument("--guidance", type=float, default=d.guidance,
                            help=f"classifier-free guidance (default: {d.guidance})")
        parser.add_argument("--contact-rate", type=float, default=d.contact_rate,
                            help=f"the planted-feet guide's step (default: {d.contact_rate}; 0: off)")
        parser.add_argument("--contact-iterations", type=int, default=d.contact_iterations,
                            help=f"the planted-feet guide's steps per x0 prediction (default: {d.contact_iterations})")
        parser.add_argument("--derive-positions", action=argparse.BooleanOptionalAction, default=d.derive_positions,
                            help="derive each x0 prediction's position channels from its rotation channels "
                                 f"(default: {d.derive_positions})")

    @staticmethod
    def from_options(args) -> TextToMotion:
        """The settings :meth:`add_options`' flags give (parsed ``args``)."""
        return TextToMotion(args.steps, args.guidance, args.contact_rate, args.contact_iterations, args.derive_positions)


TEXT_TO_MOTION = TextToMotion()  # the project's text-to-motion settings (the content bank, the demo's clips)


def denoising_steps(model, scheduler: DiffusionScheduler, x_t, start: int, num_steps: int, text=None, valid=None,
                    guidance: float = 1.0, inpaint: tuple[torch.Tensor, list[slice]] | None = None, eta: float = 0.0,
                    generator: torch.Generator | None = None, guide: Guide | None = None) -> Iterator[tuple[int, torch.Tensor]]:
    """The DDIM loop of :func:`denoise`, one step at a time: yields ``(t, x_t)``, the sample ``(B, T, D)`` that
    enters each step ``t`` of the schedule (``start`` down to 0), then ``(-1, x0)``, the result. ``guide``
    corrects each x0 prediction before the step (before ``inpaint`` overwrites its slices).

    Lazy: each prediction is made when the next item is asked for, so a consumer that needs only the steps'
    inputs (:func:`transfer.learn.reconstruction_loss`) stops before the last one. The caller chooses
    gradients (:func:`denoise` runs it under ``torch.no_grad``); tensors stay on ``x_t``'s device.
    """
    for t in scheduler.set_timesteps(num_steps, start).tolist():
        yield t, x_t
        x0 = predict_x0(model, x_t, torch.full((x_t.shape[0],), t, device=x_t.device), text, valid, guidance)
        if guide is not None:
            x0 = guide(x0)
        if inpaint is not None:
            x0 = overwrite(x0, *inpaint)
        x_t = scheduler.step(x0, t, x_t, eta=eta, generator=generator)
        if inpaint is not None:
            prev = scheduler.previous(t)
            scale = scheduler.alpha(prev, x_t).sqrt() if prev >= 0 else 1.0
            x_t = overwrite(x_t, inpaint[0] * scale, inpaint[1])
    yield -1, x_t


@torch.no_grad()
def denoise(model, scheduler: DiffusionScheduler, x_t, start: int, num_steps: int, text=None, valid=None,
            guidance: float = 1.0, inpaint: tuple[torch.Tensor, list[slice]] | None = None, eta: float = 0.0,
            generator: torch.Generator | None = None, guide: Guide | None = None) -> torch.Tensor:
    """Denoise ``x_t (B, T, D)`` (at step ``start``) to x0 in ``num_steps`` DDIM steps.

    ``inpaint = (reference (B, T, D), slices)``: at every step the x0 prediction takes the
    reference's values on those feature slices, and the noise on them is zero (Hu et al. eq. 4-5). ``guide``:
    see :func:`denoising_steps` (it runs with gradients on, inside this function's ``no_grad``).
    ``text (B, E)``, ``valid (B, T)`` and the reference are on ``x_t``'s device, where the result is.
    """
    for _, x in denoising_steps(model, scheduler, x_t, start, num_steps, text, valid, guidance, inpaint, eta, generator, guide):
        pass  # the last item is the result
    return x


def overwrite(x: torch.Tensor, reference: torch.Tensor, slices: list[slice]) -> torch.Tensor:
    """``x`` with the feature ``slices`` taken from ``reference`` (same shape)."""
    x = x.clone()
    for s in slices:
        x[..., s] = reference[..., s]
    return x


def noise_keeping(scheduler, x: torch.Tensor, noise: torch.Tensor, k, keep: list[slice]) -> torch.Tensor:
    """``x (*, T, D)`` noised to step ``k`` with ``noise``, except the feature slices ``keep`` (e.g. the root
    path), which are only scaled as the noise schedule scales a clean signal: what learning and applying a
    style start from."""
    return overwrite(scheduler.add_noise(x, noise, k), x * scheduler.alpha(k, x).sqrt(), keep)


@torch.no_grad()
def generate(model, scheduler: DiffusionScheduler, text: torch.Tensor, length: int, num_steps: int = TEXT_TO_MOTION.steps,
             guidance: float = TEXT_TO_MOTION.guidance, generator: torch.Generator | None = None, guide: Guide | None = None) -> torch.Tensor:
    """Text embeddings ``(B, E)`` -> normalised features ``(B, length, D)`` from pure noise, on the model's device
    (the noise is drawn on the CPU from ``generator``). The project's text-to-motion settings are
    :class:`TextToMotion`, drawn by :meth:`transfer.bundle.MethodBundle.text_to_motion`."""
    device = model_device(model)
    text = text.to(device)
    x = torch.randn(text.shape[0], length, model.config.feature_dim, generator=generator).to(device)
    return denoise(model, scheduler, x, scheduler.num_train_steps - 1, num_steps, text, guidance=guidance,
                   generator=generator, guide=guide)
