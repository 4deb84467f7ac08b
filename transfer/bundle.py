"""The method's models in one bundle: the diffusion prior with its noise schedule, the motion and text encoders and
the feature normalisation they were trained with (:class:`MethodBundle`), loaded from weights files
(:meth:`MethodBundle.from_pretrained`) or, for the shipped weights, once per process and device
(:func:`load_models`); and whether a style was learned on the installed prior (:func:`base_model_warning`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache, partial
from pathlib import Path

import torch

from mlcore.shipped import weights_path
from transfer.sampling import TEXT_TO_MOTION, TextToMotion, generate
from transfer.scheduler import DiffusionScheduler

PRIOR_FILE = "denoiser.safetensors"
ENCODER_FILE = "motion_encoder.safetensors"


@dataclass
class MethodBundle:
    """The prior (on its device) with its scheduler, built from its config; ``mean``/``std`` ``(D,)``, the
    features' normalisation (on the CPU, beside the motion code); the motion encoder (on the prior's device) and
    the text encoder (its embeddings on the CPU); ``prior_path``, the prior's weights file (None for models made in
    memory). Editing needs only the prior: the other parts may be None there (toy models in tests)."""

    prior: torch.nn.Module
    mean: torch.Tensor | None = None
    std: torch.Tensor | None = None
    motion_encoder: torch.nn.Module | None = None
    text_encoder: object | None = None
    prior_path: Path | None = None
    scheduler: DiffusionScheduler = field(init=False)

    def __post_init__(self):
        self.scheduler = DiffusionScheduler(self.prior.config.num_train_steps)

    def normalize(self, x: torch.Tensor, inplace: bool = False) -> torch.Tensor:
        """Raw features ``(..., D)`` -> the models' normalised features (``inplace``: in ``x``'s memory)."""
        return x.sub_(self.mean).div_(self.std) if inplace else (x - self.mean) / self.std

    def denormalize(self, x: torch.Tensor, inplace: bool = False) -> torch.Tensor:
        """Normalised features ``(..., D)`` -> raw features (``inplace``: in ``x``'s memory)."""
        return x.mul_(self.std).add_(self.mean) if inplace else x * self.std + self.mean

    def text_to_motion(self, text: torch.Tensor, length: int, generator: torch.Generator | None = None,
                       settings: TextToMotion = TEXT_TO_MOTION) -> torch.Tensor:
        """Text embeddings ``(B, E)`` -> normalised features ``(B, length, D)`` drawn by the prior from pure noise
        as ``settings`` say (:class:`transfer.sampling.TextToMotion`), on the prior's device."""
        from transfer.denoiser import derive_position_channels
        from transfer.prior import contact_guide

        contact = settings.contact_rate > 0 and settings.contact_iterations > 0
        if (contact or settings.derive_positions) and (self.mean is None or self.std is None):
            raise ValueError("text_to_motion: the planted-feet guide and derived positions need the bundle's feature "
                             "mean and std; got a bundle without them (TextToMotion(contact_rate=0, "
                             "derive_positions=False) draws without them)")
        guides = []
        if contact:
            guides.append(contact_guide(self.mean, self.std, settings.contact_rate, settings.contact_iterations))
        if settings.derive_positions:
            guides.append(partial(derive_position_channels, mean=self.mean, std=self.std))

        def guide(x0: torch.Tensor) -> torch.Tensor:
            for g in guides:
                x0 = g(x0)
            return x0

        return generate(self.prior, self.scheduler, text, length, settings.steps, settings.guidance, generator,
                        guide if guides else None)

    @classmethod
    def from_pretrained(cls, source: str | Path | tuple[Path, Path], device: str | torch.device = "cpu") -> MethodBundle:
        """The bundle of a folder holding :data:`PRIOR_FILE` and :data:`ENCODER_FILE` (e.g. the unseen-style
        protocol's development weights), or of ``(prior file, motion encoder file)``, on ``device`` (``auto``,
        ``cpu``, ``cuda``: :func:`mlcore.device.resolve_device`)."""
        from mlcore.device import resolve_device
        from transfer.motion_encoder import load_motion_encoder
        from transfer.prior import load_prior
        from transfer.text_encoder import default_text_encoder

        prior_path, encoder_path = (Path(source) / PRIOR_FILE, Path(source) / ENCODER_FILE) if isinstance(source, (str, Path)) else source
        for path in (prior_path, encoder_path):
            if not Path(path).is_file():
                raise FileNotFoundError(f"{path}: no such weights file")
        device = resolve_device(device)
        prior, mean, std = load_prior(prior_path)
        encoder = load_motion_encoder(encoder_path)
        return cls(prior.to(device), mean, std, encoder.to(device), default_text_encoder(), Path(prior_path))


def load_models(device: str | torch.device = "cpu") -> MethodBundle:
    """The shipped models' bundle on ``device`` (see :meth:`MethodBundle.from_pretrained`), loaded once per
    process and device."""
    from mlcore.device import resolve_device

    return _shipped_on(str(resolve_device(device)))


@lru_cache(maxsize=2)
def _shipped_on(device: str) -> MethodBundle:
    return MethodBundle.from_pretrained((weights_path(PRIOR_FILE), weights_path(ENCODER_FILE)), device)


@lru_cache(maxsize=4)
def _sha256(path: Path) -> str:
    from transfer.style_file import file_sha256

    return file_sha256(path)


def base_model_warning(style, source: Path) -> str | None:
    """A one-line warning when ``style`` was learned on another prior than the installed one, else None."""
    learned_on = style.meta.get("base_model_sha256")
    if learned_on is None:
        return None
    installed = _sha256(weights_path(PRIOR_FILE))  # the file load_models reads; no model is loaded for this
    if learned_on == installed:
        return None
    return (f"warning: {source}: learned on another prior (sha256 {learned_on[:12]}…, installed "
            f"{installed[:12]}…); results may differ from where it was made")
