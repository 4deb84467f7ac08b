"""Saving and loading the project's models: weights with their config in safetensors metadata (nothing is
ever unpickled), an optional JSON model card beside them, and resumable training checkpoints
(:class:`RunCheckpoint`: modules, optimizer moments as plain tensors, config, step). Every model module
(denoiser, motion encoder, classifiers, Park et al.'s networks) and every trainer saves and loads
through here."""
from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import torch
from safetensors.torch import load_file, save_file
from torch import nn


def save_model(model: nn.Module, config, path: Path, card: dict | None = None, extra: dict[str, torch.Tensor] | None = None) -> None:
    """Weights to ``path`` (safetensors, config in its metadata) and an optional JSON model card beside it."""
    from motioncore.files import atomic_output, atomic_write_text

    path = Path(path)
    tensors = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    tensors.update({k: v.cpu() for k, v in (extra or {}).items()})
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


def resumed_config(path: Path, config, explicit: dict):
    """The config a run goes on with: the one saved in the checkpoint at ``path`` when there is one (so a
    resumed run keeps its own settings), else ``config``. ``explicit``: settings the user gave; they must
    match the saved ones (:meth:`RunCheckpoint.resume` refuses a clash). Fields the saved config lacks (an
    older checkpoint) keep ``config``'s values."""
    from dataclasses import fields, replace

    from safetensors import safe_open

    path = Path(path)
    if not path.is_file():
        return config
    with safe_open(str(path), framework="pt") as f:
        saved = json.loads((f.metadata() or {}).get("config", "{}"))
    known = {f.name for f in fields(config)}
    current = asdict(config)
    kept = {k: type(current[k])(v) if isinstance(current[k], tuple) else v for k, v in saved.items() if k in known}
    return replace(config, **{k: v for k, v in kept.items() if k not in explicit})


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
                opt.state[p] = {k: v if k == "step" else v.to(p.device) for k, v in state.items()}


def optimizer_path(path: Path) -> Path:
    """Where the optimizer moments of the run checkpoint at ``path`` live: ``<stem>.optim.safetensors``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.optim{path.suffix}")


def _load_moments(path: Path, step: str) -> dict[str, torch.Tensor]:
    from safetensors import safe_open

    if not path.is_file():
        raise ValueError(f"{path}: missing; the run checkpoint beside it needs its optimizer moments to resume")
    with safe_open(str(path), framework="pt") as f:
        saved = (f.metadata() or {}).get("step")
    if saved != step:
        raise ValueError(f"{path}: expected the moments of step {step}, got step {saved}; copy both checkpoint files together")
    return load_file(str(path))


class RunCheckpoint:
    """A training run's state in two safetensors files: ``path`` holds each named module's weights (keys
    ``<name>.<param>``) and in its metadata the config dataclass, the step and the seconds trained;
    :func:`optimizer_path` beside it holds each named optimizer's moments (keys ``<name>.opt.<param>.<state>``;
    the optimizer named ``""`` has keys ``opt.<param>.<state>``) and the same step. Two files keep each one
    under the size a repository accepts for a committed campaign checkpoint; a checkpoint written as one
    file (older versions, moments inside ``path``) still resumes. Resuming with explicit settings that
    differ from the saved config is an error, never a silent override, except for the fields that the config's
    class lists in ``STAGE_FIELDS`` (a new stage of the same run, e.g. the prior's precision or FK weight). Tensors are saved from, and loaded
    onto, the modules' own devices.

    ``param_names``: optimizer parameter ``id`` -> the name its moments are stored under.
    """

    def __init__(self, path: Path, config, modules: dict[str, nn.Module],
                 optimizers: dict[str, torch.optim.Optimizer], param_names: dict[int, str]):
        self.path, self.config = Path(path), config
        self.modules, self.optimizers, self.param_names = modules, optimizers, param_names
        self.step, self.elapsed = 0, 0.0

    def save(self) -> None:
        from motioncore.files import atomic_output

        tensors, moments = {}, {}
        for name, module in self.modules.items():
            tensors.update({f"{name}.{k}": v.detach().cpu().contiguous() for k, v in module.state_dict().items()})
        for name, opt in self.optimizers.items():
            prefix = f"{name}." if name else ""
            moments.update({prefix + k: v.cpu() for k, v in optimizer_tensors(opt, self.param_names).items()})
        meta = {"config": json.dumps(asdict(self.config)), "step": str(self.step), "elapsed": f"{self.elapsed:.1f}"}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # moments first: the weights file's step is what a resume trusts, and it must find moments of that step
        with atomic_output(optimizer_path(self.path), ".tmp") as tmp:
            save_file(moments, str(tmp), metadata={"step": str(self.step)})
        with atomic_output(self.path, ".tmp") as tmp:
            save_file(tensors, str(tmp), metadata=meta)

    def resume(self, explicit: dict) -> bool:
        """Load the checkpoint if there is one (False if not). ``explicit``: settings the user gave, which
        must match the saved config."""
        from safetensors import safe_open

        if not self.path.is_file():
            return False
        with safe_open(str(self.path), framework="pt") as f:
            meta = f.metadata()
        saved = json.loads(meta["config"])
        given = json.loads(json.dumps(explicit))  # tuples compare as the lists JSON gives back
        stage = getattr(self.config, "STAGE_FIELDS", ())  # a new stage of the run may change these
        clash = {k: (saved.get(k), v) for k, v in given.items() if k in saved and saved[k] != v and k not in stage}
        if clash:
            detail = ", ".join(f"{k}: checkpoint {a!r} vs given {b!r}" for k, (a, b) in clash.items())
            raise ValueError(f"{self.path}: cannot resume with different settings ({detail}); use a new output folder")
        tensors = load_file(str(self.path))
        if self.optimizers and not any(".opt." in k or k.startswith("opt.") for k in tensors):
            tensors.update(_load_moments(optimizer_path(self.path), meta["step"]))
        for name, module in self.modules.items():
            prefix = f"{name}."
            module.load_state_dict({k[len(prefix):]: v for k, v in tensors.items() if k.startswith(prefix)})
        for name, opt in self.optimizers.items():
            prefix = f"{name}." if name else ""
            load_optimizer(opt, self.param_names, {k[len(prefix):]: v for k, v in tensors.items() if k.startswith(prefix + "opt.")})
        self.step, self.elapsed = int(meta["step"]), float(meta.get("elapsed", 0))
        return True
