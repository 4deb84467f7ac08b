"""Saving and loading the project's models: weights with their config in safetensors metadata (nothing is
ever unpickled), an optional JSON model card beside them, and optimizer state as plain tensors for
resumable training checkpoints. Every model module (denoiser, motion encoder, classifiers, Park et
al.'s networks) and every trainer saves and loads through here."""
from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import torch
from safetensors.torch import save_file
from torch import nn


def save_model(model: nn.Module, config, path: Path, card: dict | None = None, extra: dict[str, torch.Tensor] | None = None) -> None:
    """Weights to ``path`` (safetensors, config in its metadata) and an optional JSON model card beside it."""
    from motioncore.files import atomic_output, atomic_write_text

    path = Path(path)
    tensors = {k: v.detach().contiguous() for k, v in model.state_dict().items()}
    tensors.update(extra or {})
    with atomic_output(path, ".tmp") as tmp:
        save_file(tensors, str(tmp), metadata={"config": json.dumps(asdict(config)), "class": type(config).__name__})
    if card is not None:
        atomic_write_text(path.with_suffix(".json"), json.dumps(card, indent=1))


def load_config(path: Path, cls):
    """The dataclass config stored in a safetensors file's metadata (no unpickling)."""
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
    if meta.get("class") != cls.__name__:
        raise ValueError(f"{path}: expected a {cls.__name__} checkpoint, got {meta.get('class')!r}")
    return cls(**json.loads(meta["config"]))


def optimizer_tensors(opt: torch.optim.Optimizer, names: dict[int, str]) -> dict[str, torch.Tensor]:
    out = {}
    for group in opt.param_groups:
        for p in group["params"]:
            for k, v in opt.state.get(p, {}).items():
                if torch.is_tensor(v):
                    out[f"opt.{names[id(p)]}.{k}"] = v.detach().clone().reshape(v.shape or (1,)).contiguous()
    return out


def load_optimizer(opt: torch.optim.Optimizer, names: dict[int, str], tensors: dict[str, torch.Tensor]) -> None:
    for group in opt.param_groups:
        for p in group["params"]:
            prefix = f"opt.{names[id(p)]}."
            state = {k[len(prefix):]: v for k, v in tensors.items() if k.startswith(prefix)}
            if state:
                if "step" in state:
                    state["step"] = state["step"].reshape(())
                opt.state[p] = state
