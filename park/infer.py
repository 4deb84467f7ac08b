"""Inference with a trained Park et al. stylizer on normalised canonical features ``(T, D)``.

Style codes come from noise + domain (the style label; mapping network F) or from a reference motion + domain (style
encoder E). Content of any length is stylised in ``config.window``-frame windows overlapping by a
quarter window and crossfaded; clips shorter than a window (or not a multiple of 4 frames) are
padded with their last frame and cropped back. Every output keeps the content's root trajectory:
the root velocity slices ``FEATURES.root_rvel`` and ``FEATURES.root_lvel`` are overwritten with the
content's, as the main method does (root height and everything else come from the network).
"""
from __future__ import annotations

from itertools import combinations
from pathlib import Path

import torch
from safetensors.torch import load_file

from mlcore.checkpoints import load_config
from mlcore.device import model_device, resolve_device
from motioncore.representation import FEATURES, decode_positions
from park.networks import ParkConfig, ParkModel

ROOT_SLICES = (FEATURES.root_rvel, FEATURES.root_lvel)


def load_park(path: Path | str, device: str | torch.device = "cpu") -> ParkModel:
    """G, E, F from safetensors (config in the metadata; nothing is unpickled), in eval mode on ``device``
    (``"auto"``, ``"cpu"``, ``"cuda"``: :func:`mlcore.device.resolve_device`). The functions below take
    inputs on any device and return results on the input's device (codes on the model's)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no Park stylizer weights; train them with park.train.train_park")
    try:
        model = ParkModel(load_config(path, ParkConfig))
        model.load_state_dict(load_file(str(path)))
    except Exception as e:  # noqa: BLE001 - safetensors, json and torch each raise their own errors on garbage
        raise ValueError(f"{path}: not Park stylizer weights ({str(e).splitlines()[0][:160]})") from None
    return model.to(resolve_device(device)).eval()


def _pad4(x: torch.Tensor, length: int | None = None) -> torch.Tensor:
    """``(T, D)`` padded with its last frame to ``length`` (default: the next multiple of 4)."""
    t = x.shape[0]
    target = max(length or 0, -(-t // 4) * 4)
    return torch.cat([x, x[-1:].expand(target - t, -1)]) if target > t else x


@torch.no_grad()
def code_from_noise(model: ParkModel, style_label: str, seed: int, n: int = 1) -> torch.Tensor:
    """``(n, style_dim)`` style codes ``F(z, style_label)`` for ``z`` drawn from a generator seeded with ``seed``."""
    dev = model_device(model)
    z = torch.randn(n, model.config.latent_dim, generator=torch.Generator().manual_seed(seed)).to(dev)
    return model.f(z, torch.full((n,), model.domain_index(style_label), dtype=torch.long, device=dev))


@torch.no_grad()
def code_from_reference(model: ParkModel, reference: torch.Tensor, style_label: str) -> torch.Tensor:
    """``(style_dim,)`` style code ``E_domain(reference)`` of a normalised reference motion ``(T', D)`` (whole clip)."""
    if reference.ndim != 2 or reference.shape[1] != model.config.feature_dim:
        raise ValueError(f"reference: expected (T, {model.config.feature_dim}), got {tuple(reference.shape)}")
    dev = model_device(model)
    y = torch.tensor([model.domain_index(style_label)], device=dev)
    return model.e(_pad4(reference.float().to(dev))[None], y)[0]


@torch.no_grad()
def generate(model: ParkModel, content: torch.Tensor, code: torch.Tensor, overlap: int | None = None) -> torch.Tensor:
    """``G(content, code)`` over windows (overlap default: a quarter window) with crossfades; the content's root velocities are kept. -> ``(T, D)``."""
    from mlcore.windows import crossfade, window_starts

    if content.ndim != 2 or content.shape[1] != model.config.feature_dim:
        raise ValueError(f"content: expected (T, {model.config.feature_dim}), got {tuple(content.shape)}")
    dev = model_device(model)
    x, s = content.float().to(dev), code.reshape(1, -1).float().to(dev)
    n, window = x.shape[0], model.config.window
    overlap = window // 4 if overlap is None else overlap
    starts = window_starts(n, window, overlap)
    chunks = []
    for st in starts:
        part = x[st:st + window]
        chunks.append(model.g(_pad4(part)[None], s)[0, :part.shape[0]])
    out = crossfade(chunks, starts, n) if len(chunks) > 1 else chunks[0].clone()
    for sl in ROOT_SLICES:
        out[:, sl] = x[:, sl]
    return out.to(content.device)


def stylize_noise(model: ParkModel, content: torch.Tensor, style_label: str, seed: int = 0, n_variants: int = 1) -> list[torch.Tensor]:
    """``n_variants`` stylisations of ``content`` into ``style_label``, one per noise draw (deterministic in ``seed``)."""
    return [generate(model, content, c) for c in code_from_noise(model, style_label, seed, n_variants)]


def stylize_reference(model: ParkModel, content: torch.Tensor, reference: torch.Tensor, style_label: str) -> torch.Tensor:
    """``content`` in the style of ``reference``, read as a motion of ``style_label``."""
    return generate(model, content, code_from_reference(model, reference, style_label))


def mixed_code(code_a: torch.Tensor, code_b: torch.Tensor, alpha: float) -> torch.Tensor:
    """The interpolated code ``(1 - alpha) code_a + alpha code_b`` ``(style_dim,)`` (within or across domains)."""
    return torch.lerp(code_a.reshape(-1), code_b.reshape(-1), float(alpha))


def mix(model: ParkModel, content: torch.Tensor, code_a: torch.Tensor, code_b: torch.Tensor, alpha: float) -> torch.Tensor:
    """Stylise with :func:`mixed_code` of the two codes."""
    return generate(model, content, mixed_code(code_a, code_b, alpha))


def park_method(model: ParkModel, seed: int = 0):
    """A :mod:`evaluation.protocol` method: the style example's code (E, domain = the style label) applied to the content.

    ``seed`` seeds torch's global generator once per call; the reference path itself is deterministic.
    """
    def transfer(content_feats: torch.Tensor, style_example: torch.Tensor, style_label: str,
                 content_label: str) -> torch.Tensor:
        torch.manual_seed(seed)
        return stylize_reference(model, content_feats, style_example, style_label)

    return transfer


def pairwise_diversity(outputs: list[torch.Tensor], mean: torch.Tensor | None = None, std: torch.Tensor | None = None) -> dict:
    """Mean over pairs of outputs (same content and domain, different noise) of their distance.

    ``feature_l1``: mean absolute difference of the normalised features; with ``mean``/``std`` also
    ``position_m``: mean per-joint distance (metres) of the decoded positions (root path included).
    """
    if len(outputs) < 2:
        raise ValueError("pairwise_diversity: need at least 2 outputs")
    pairs = list(combinations(range(len(outputs)), 2))
    out = {"feature_l1": sum(float((outputs[i] - outputs[j]).abs().mean()) for i, j in pairs) / len(pairs), "pairs": len(pairs)}
    if mean is not None and std is not None:
        pos = [decode_positions((o * std + mean).double()) for o in outputs]
        out["position_m"] = sum(float((pos[i] - pos[j]).norm(dim=-1).mean()) for i, j in pairs) / len(pairs)
    return out
