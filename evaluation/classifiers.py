"""ST-GCN content and style classifiers for Bandai-2 (evaluation after Hu et al. 2024 §4.2).

One architecture for both targets: ST-GCN blocks (``park/graph.py``) over the canonical
skeleton graph, a masked global average over frames and joints (:meth:`MotionClassifier.features`,
the vector FMD uses) and a linear layer (:meth:`MotionClassifier.logits`).

Training (:func:`train_classifier`): the train split of the cache, Bandai-2 clips only (dataset-1
has other contents and few styles), mirrored copies included (their content labels are already
swapped). Each step draws a class uniformly, then a clip of that class, then a random window of
``min_window..max_window`` frames (one length per batch; shorter clips are zero-padded and masked).
Validation (logged) and the final test accuracy run on *whole* clips of the val / test split,
zero-padded in batches and masked, which gives the same result as one clip at a time.

Inputs are features normalised with the classifier's own ``mean``/``std`` buffers (saved in the
weights; the cache's train statistics at training time): use :meth:`MotionClassifier.normalize`
on raw features.
"""
from __future__ import annotations

import json
import math
import random
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch
from safetensors.torch import load_file
from torch import nn
from torch.nn import functional as F

from mlcore.captions import BANDAI2_CONTENTS
from mlcore.checkpoints import load_config, save_model
from mlcore.dataset import LABELS, MotionDataset, labelled_clips
from mlcore.device import model_device, resolve_device
from mlcore.shipped import weights_dir
from mlcore.training import Trainer
from motioncore.representation import FEATURES
from park.graph import (
    GRAPH_CHANNELS,
    STGCNBlock,
    canonical_adjacency,
    features_to_graph,
    masked_mean,
    valid_to_mask,
)


def default_weights(target: str) -> Path:
    """``classifier_{target}.safetensors`` in :func:`mlcore.shipped.weights_dir`."""
    return weights_dir() / f"classifier_{target}.safetensors"


@dataclass
class ClassifierConfig:
    target: str = "content"
    classes: list[str] = field(default_factory=lambda: list(BANDAI2_CONTENTS))
    channels: list[int] = field(default_factory=lambda: [32, 64, 64, 128])
    strides: list[int] = field(default_factory=lambda: [2, 2, 1, 1])
    temporal_kernel: int = 9
    dropout: float = 0.2
    feature_dim: int = FEATURES.dim


class MotionClassifier(nn.Module):
    """``(B, T, D)`` normalised features (+ ``valid (B, T)``) -> logits over ``config.classes``."""

    def __init__(self, config: ClassifierConfig):
        super().__init__()
        if len(config.channels) != len(config.strides):
            raise ValueError(f"MotionClassifier: channels {config.channels} and strides {config.strides} differ in length")
        if config.feature_dim != FEATURES.dim:
            raise ValueError(f"MotionClassifier: built for {config.feature_dim}-d features, this code has {FEATURES.dim}")
        self.config = config
        self.register_buffer("mean", torch.zeros(config.feature_dim))
        self.register_buffer("std", torch.ones(config.feature_dim))
        adjacency = canonical_adjacency()
        blocks, c_in = [], GRAPH_CHANNELS
        for i, (c, s) in enumerate(zip(config.channels, config.strides)):
            blocks.append(STGCNBlock(c_in, c, adjacency, config.temporal_kernel, s, residual=i > 0, norm="batch",
                                     dropout=config.dropout if i > 0 else 0.0))
            c_in = c
        self.blocks = nn.ModuleList(blocks)
        self.head = nn.Linear(c_in, len(config.classes))
        self.drop = nn.Dropout(config.dropout)

    def standardize(self, raw: torch.Tensor) -> torch.Tensor:
        """Raw features ``(*, D)`` -> the model's input, on ``raw``'s device."""
        return (raw - self.mean.to(raw.device)) / self.std.to(raw.device)

    def features(self, x: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        """Pooled feature vector ``(B, channels[-1])``: masked mean over frames and joints of the last block."""
        if x.ndim != 3 or x.shape[-1] != self.config.feature_dim:
            raise ValueError(f"MotionClassifier: expected (B, T, {self.config.feature_dim}), got {tuple(x.shape)}")
        h = features_to_graph(x)
        mask = valid_to_mask(valid, x.shape[1])
        for block in self.blocks:
            h = block(h, mask)
            if mask is not None and block.stride > 1:
                mask = mask[:, :, ::block.stride]
        return masked_mean(h, mask)

    def logits(self, x: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        return self.head(self.drop(self.features(x, valid)))

    def forward(self, x: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        return self.logits(x, valid)

    def label_index(self, labels: Sequence[str | int]) -> torch.Tensor:
        """Class names (or indices) -> ``(N,)`` indices; unknown names are an error."""
        out = []
        for lab in labels:
            if isinstance(lab, str):
                if lab not in self.config.classes:
                    raise KeyError(f"{lab!r} is not a {self.config.target} class ({', '.join(self.config.classes)})")
                out.append(self.config.classes.index(lab))
            else:
                out.append(int(lab))
        return torch.tensor(out, dtype=torch.long)


def pad_batch(clips: Sequence[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
    """Clips ``(T_i, D)`` -> zero-padded ``(B, max T, D)`` and ``valid (B, max T)``."""
    t = max(c.shape[0] for c in clips)
    x = clips[0].new_zeros(len(clips), t, clips[0].shape[1])
    valid = torch.zeros(len(clips), t, dtype=torch.bool)
    for i, c in enumerate(clips):
        x[i, :c.shape[0]] = c
        valid[i, :c.shape[0]] = True
    return x, valid


@torch.no_grad()
def run_batched(model: MotionClassifier, clips: Sequence[torch.Tensor], what: str = "logits", batch_size: int = 32) -> torch.Tensor:
    """``model.logits`` or ``model.features`` of whole clips (normalised for the model), batched by length."""
    if not len(clips):
        raise ValueError("run_batched: no clips")
    was_training = model.training
    model.eval()
    order = sorted(range(len(clips)), key=lambda i: clips[i].shape[0])
    outs: list[torch.Tensor] = [None] * len(clips)  # type: ignore[list-item]
    fn = model.logits if what == "logits" else model.features
    for s in range(0, len(order), batch_size):
        idx = order[s:s + batch_size]
        x, valid = pad_batch([clips[i].float() for i in idx])
        dev = model_device(model)
        for i, row in zip(idx, fn(x.to(dev), valid.to(dev)).to(x.device)):
            outs[i] = row
    model.train(was_training)
    return torch.stack(outs)


def load_classifier(path: Path | str) -> MotionClassifier:
    """A classifier from safetensors (config in the metadata; nothing is unpickled), in eval mode."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no classifier weights; train them with evaluation.classifiers.train_classifier")
    model = MotionClassifier(load_config(path, ClassifierConfig))
    model.load_state_dict(load_file(str(path)))
    return model.eval()


# ------------------------------------------------------------------------------------ training

@dataclass
class ClassifierTrainConfig:
    target: str = "content"
    channels: list[int] = field(default_factory=lambda: [32, 64, 64, 128])
    strides: list[int] = field(default_factory=lambda: [2, 2, 1, 1])
    temporal_kernel: int = 9
    dropout: float = 0.2
    batch_size: int = 32
    min_window: int = 60
    max_window: int = 80
    lr: float = 2e-3
    warmup: int = 100
    weight_decay: float = 1e-3
    ema: float = 0.995
    label_smoothing: float = 0.1
    seed: int = 0

    def model_config(self) -> ClassifierConfig:
        return ClassifierConfig(target=self.target, classes=list(LABELS[self.target]), channels=list(self.channels),
                                strides=list(self.strides), temporal_kernel=self.temporal_kernel, dropout=self.dropout)


def _sample_batch(data: MotionDataset, by_class: list[list[int]], n: int, window: int, gen: torch.Generator):
    """Class-balanced random windows: ``x (n, window, D)``, ``valid``, ``y``."""
    classes = [c for c, members in enumerate(by_class) if members]
    y = torch.tensor([classes[int(k)] for k in torch.randint(len(classes), (n,), generator=gen)])
    x = torch.zeros(n, window, data.features.shape[1])
    valid = torch.zeros(n, window, dtype=torch.bool)
    for b, c in enumerate(y.tolist()):
        members = by_class[c]
        r = data.records[members[int(torch.randint(len(members), (1,), generator=gen))]]
        length = min(window, r.length)
        s = int(torch.randint(r.length - length + 1, (1,), generator=gen))
        x[b, :length] = data.standardize(data.features[r.start + s:r.start + s + length])
        valid[b, :length] = True
    return x, valid, y


def evaluate_clips(model: MotionClassifier, data: MotionDataset, idx: list[int], labels: list[int]) -> dict:
    """Accuracy and confusion matrix (rows = true class, columns = predicted) on whole clips."""
    clips = [model.standardize(data.clip(i, normalized=False)) for i in idx]
    pred = run_batched(model, clips).argmax(-1)
    y = torch.tensor(labels)
    k = len(model.config.classes)
    confusion = torch.zeros(k, k, dtype=torch.long)
    confusion.index_put_((y, pred), torch.ones_like(y), accumulate=True)
    return {"accuracy": float((pred == y).float().mean()), "confusion": confusion.tolist(), "n": len(idx)}


def train_classifier(data_dir: Path, out_dir: Path, target: str = "content", max_minutes: float = 10.0,
                     max_steps: int = 3000, config: ClassifierTrainConfig | None = None, weights_path: Path | None = None,
                     explicit: dict | None = None, eval_every: int = 250, progress: bool = True,
                     device: str = "cpu") -> dict:
    """Train (or resume) a ``target`` classifier; checkpoints and ``log.csv`` in ``out_dir``.

    Stops at ``max_steps`` or after ``max_minutes`` (this call), exports the EMA weights to
    ``weights_path`` (default :func:`default_weights`) with a JSON model card holding the test
    accuracy and confusion matrix, and returns that card.
    ``device``: auto, cpu or cuda (:func:`mlcore.device.resolve_device`); the exported weights are CPU tensors.
    """
    if target not in LABELS:
        raise ValueError(f"train_classifier: target must be one of {sorted(LABELS)}, got {target!r}")
    config = config or ClassifierTrainConfig(target=target)
    if config.target != target:
        raise ValueError(f"train_classifier: config.target {config.target!r} != target {target!r}")
    if not 1 <= config.min_window <= config.max_window:
        raise ValueError(f"train_classifier: expected 1 <= min_window <= max_window, got {config.min_window}, {config.max_window}")
    out_dir = Path(out_dir)
    weights_path = Path(weights_path) if weights_path is not None else default_weights(target)
    torch.manual_seed(config.seed)
    random.seed(config.seed)

    train, train_idx, train_y = labelled_clips(data_dir, "train", target)
    if not train_idx:
        raise ValueError(f"{data_dir}: no Bandai-2 train clips with {target} labels")
    by_class = [[i for i, y in zip(train_idx, train_y) if y == c] for c in range(len(LABELS[target]))]
    val, val_idx, val_y = labelled_clips(data_dir, "val", target)
    test, test_idx, test_y = labelled_clips(data_dir, "test", target)

    model = MotionClassifier(config.model_config())  # made on the CPU (the same seeded weights anywhere), then moved
    model.mean.copy_(train.mean)
    model.std.copy_(train.std)
    dev = resolve_device(device)
    model.to(dev)
    trainer = Trainer(model, config, out_dir, lr=config.lr, warmup=config.warmup, ema=config.ema, weight_decay=config.weight_decay)
    trainer.resume(explicit or {})
    gen = torch.Generator().manual_seed(config.seed * 1000003 + trainer.step)

    def loss_fn(m, step):
        window = int(torch.randint(config.min_window, config.max_window + 1, (1,), generator=gen))
        x, valid, y = (t.to(dev) for t in _sample_batch(train, by_class, config.batch_size, window, gen))
        logits = m(x, valid)
        loss = F.cross_entropy(logits, y, label_smoothing=config.label_smoothing)
        # "val_acc" is present (empty) in every row so the CSV header, fixed by the first row, has its column
        return loss, {"train_acc": float((logits.argmax(-1) == y).float().mean()), "window": window, "val_acc": ""}

    def evaluate(ema, step):
        return {"val_acc": evaluate_clips(ema, val, val_idx, val_y)["accuracy"]} if val_idx else {}

    # the learning rate decays with a cosine over max_steps (the Trainer applies warmup to self.lr)
    base_lr = config.lr

    def scheduled_loss(m, step):
        trainer.lr = base_lr * 0.5 * (1 + math.cos(math.pi * min(1.0, step / max(1, max_steps))))
        return loss_fn(m, step)

    trainer.run(scheduled_loss, max_steps, max_minutes, progress=progress, evaluate=evaluate, eval_every=eval_every)

    result = evaluate_clips(trainer.ema, test, test_idx, test_y) if test_idx else {"accuracy": None, "confusion": None, "n": 0}
    val_result = evaluate_clips(trainer.ema, val, val_idx, val_y) if val_idx else {"accuracy": None}
    card = {
        "model": f"video2style {target} classifier (ST-GCN, Yan et al. 2018; spatial partitions after Park et al. 2021)",
        "classes": list(LABELS[target]),
        "data": f"Bandai-Namco-Research-Motiondataset-2, train split of {Path(data_dir).name} (with mirrored copies), 20 fps, "
                f"class-balanced random windows of {config.min_window}-{config.max_window} frames",
        "evaluation": "whole clips (zero-padded in batches and masked), Bandai-2 test split including mirrored copies",
        "licence": "CC BY-NC 4.0, inherited from the Bandai-Namco training data",
        "steps": trainer.step,
        "max_steps": max_steps,  # the cosine learning-rate schedule spans this many steps
        "wall_time_minutes": round(trainer.elapsed / 60, 1),
        "torch_threads": torch.get_num_threads(),
        "val_accuracy": val_result["accuracy"],
        "test_accuracy": result["accuracy"],
        "test_clips": result["n"],
        "test_confusion": {"rows_true_columns_predicted": list(LABELS[target]), "matrix": result["confusion"]},
        "train_config": asdict(config),
        "model_config": asdict(trainer.ema.config),
        "parameters": sum(p.numel() for p in trainer.ema.parameters()),
        "machine": "2 CPU cores",
        "date": time.strftime("%Y-%m-%d"),
    }
    save_model(trainer.ema, trainer.ema.config, weights_path, card)
    return card


def read_card(path: Path | str) -> dict:
    """The JSON model card beside a weights file."""
    return json.loads(Path(path).with_suffix(".json").read_text())
