"""Low-rank adapters (LoRA) on a model's ``nn.Linear`` layers, so a learned style is a small file."""
from __future__ import annotations

import math

import torch
from torch import nn


class LoRALinear(nn.Module):
    """``base(x) + scale * B(A(x))`` with ``A (r, in)``, ``B (out, r)``; B starts at zero (no change).

    The adapters live on the base layer's device; A's random start is drawn on the CPU (torch's global
    generator, as seeded by the caller), so a seed gives the same start on any device.
    """

    def __init__(self, base: nn.Linear, rank: int, alpha: float):
        super().__init__()
        self.base = base
        self.rank = rank
        self.scale = alpha / rank
        a = torch.empty(rank, base.in_features)
        nn.init.kaiming_uniform_(a, a=math.sqrt(5))
        self.lora_a = nn.Parameter(a.to(base.weight.device))
        self.lora_b = nn.Parameter(torch.zeros(base.out_features, rank, device=base.weight.device))
        self.gain = 1.0  # multiplies the adapters' output (1: as learned, 0: the base model)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.base(x) + (self.gain * self.scale) * ((x @ self.lora_a.T) @ self.lora_b.T)


TARGETS = ("q", "k", "v", "o", "ff1", "ff2")


def add_lora(model: nn.Module, rank: int = 8, alpha: float = 8.0, targets: tuple[str, ...] = TARGETS) -> list[str]:
    """Wrap every ``nn.Linear`` named in ``targets`` (inside transformer blocks); freeze everything else.

    Returns the wrapped modules' names.
    """
    for p in model.parameters():
        p.requires_grad_(False)
    wrapped = []
    for name, module in list(model.named_modules()):
        for child_name, child in list(module.named_children()):
            if child_name in targets and isinstance(child, nn.Linear):
                setattr(module, child_name, LoRALinear(child, rank, alpha))
                wrapped.append(f"{name}.{child_name}" if name else child_name)
    if not wrapped:
        raise ValueError(f"add_lora: no nn.Linear named {targets} found")
    return wrapped


def lora_state(model: nn.Module) -> dict[str, torch.Tensor]:
    """Only the adapter tensors, keyed by module path, copied to the CPU (what a style file holds)."""
    return {k: v.detach().cpu().clone() for k, v in model.state_dict().items() if k.endswith(("lora_a", "lora_b"))}


def load_lora_state(model: nn.Module, tensors: dict[str, torch.Tensor]) -> None:
    """Load adapter tensors; ValueError (one line) when their names or shapes do not fit the model."""
    state = model.state_dict()
    own = {k for k in state if k.endswith(("lora_a", "lora_b"))}
    if set(tensors) != own:
        missing, extra = sorted(own - set(tensors)), sorted(set(tensors) - own)
        raise ValueError(f"adapter tensors do not fit the model: missing {missing[:3]}, unexpected {extra[:3]}")
    for k in sorted(own):
        if tensors[k].shape != state[k].shape:
            raise ValueError(f"adapter tensor {k}: expected shape {tuple(state[k].shape)}, got {tuple(tensors[k].shape)}")
    model.load_state_dict(tensors, strict=False)


def set_gain(model: nn.Module, gain: float) -> None:
    """Scale every adapter's output by ``gain`` (``apply --strength`` is another thing: how far the clip is noised)."""
    for m in model.modules():
        if isinstance(m, LoRALinear):
            m.gain = gain
