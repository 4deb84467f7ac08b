"""A second, independent opinion on style: hand-made motion features and a linear classifier.

The protocol's style classifier is an ST-GCN trained on the same features the style models learn on, so a
change that fools it need not look like the style to anyone else. This judge shares no network with the method:
per clip, statistics a person would name (:func:`judge_features`: where each joint is held and how far it
swings in the hips' facing frame, how fast each joint moves, how high the hips ride, how fast the body travels
and turns), standardised, and a multinomial logistic regression (:class:`HandJudge`) fitted on the cache's
train split. It reports two things about a set of transfers (:func:`judge_scores`):

- ``judge_sra``: the share of outputs the judge reads as their target style;
- ``judge_toward``: the share whose features moved towards the target style, i.e. closer to the mean of the
  train clips of the content's action in the target style than the content itself was (all in standardised
  units; closer by more than :data:`TOWARD_MARGIN` of the distance). The unchanged content scores 0.
"""
from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path

import torch

from mlcore.captions import STYLES
from mlcore.dataset import MotionDataset
from motioncore.representation import FEATURES
from motioncore.skeleton import CANONICAL

JUDGE_WEIGHT_DECAY = 1e-3  # L2 on the logistic regression's weights (standardised features)
TOWARD_MARGIN = 1e-3  # a distance must shrink by more than this share to count as a move (not float round-off)


def judge_features(raw: torch.Tensor, fps: float = CANONICAL.fps) -> torch.Tensor:
    """Hand-made style features ``(F,)`` of one clip's raw (unnormalised) features ``(T, D)``: per joint its mean
    place and its standard deviation in the hips' facing frame (metres), its mean speed (m/s); the root height's
    mean and standard deviation, the root's mean planar speed (m/s) and mean absolute turning rate (rad/s)."""
    if raw.ndim != 2 or raw.shape[1] != FEATURES.dim or raw.shape[0] < 2:
        raise ValueError(f"judge_features: expected raw features (T >= 2, {FEATURES.dim}), got {tuple(raw.shape)}")
    raw = raw.double()
    pos = raw[:, FEATURES.positions].unflatten(-1, (-1, 3))  # (T, J-1, 3)
    speed = (pos[1:] - pos[:-1]).norm(dim=-1).mean(0) * fps  # (J-1,)
    height = raw[:, FEATURES.root_height.start]
    root_speed = raw[:-1, FEATURES.root_lvel].norm(dim=-1).mean() * fps
    turning = raw[:-1, FEATURES.root_rvel.start].abs().mean() * fps
    return torch.cat([pos.mean(0).flatten(), pos.std(0).flatten(), speed,
                      torch.stack([height.mean(), height.std(), root_speed, turning])]).float()


class HandJudge:
    """Multinomial logistic regression over standardised :func:`judge_features`; ``classes`` are style names."""

    def __init__(self, classes: Sequence[str], mean: torch.Tensor, std: torch.Tensor, weight: torch.Tensor | None,
                 bias: torch.Tensor | None):
        self.classes, self.mean, self.std, self.weight, self.bias = list(classes), mean, std, weight, bias

    @classmethod
    def fit(cls, feats: torch.Tensor, labels: Sequence[str], classes: Sequence[str] = STYLES,
            weight_decay: float = JUDGE_WEIGHT_DECAY, iterations: int = 300) -> HandJudge:
        """Fit on ``feats (N, F)`` with style names ``labels`` (full-batch L-BFGS; deterministic)."""
        if feats.ndim != 2 or feats.shape[0] != len(labels):
            raise ValueError(f"HandJudge.fit: expected feats (N, F) and N labels, got {tuple(feats.shape)} and {len(labels)}")
        classes = list(classes)
        y = torch.tensor([classes.index(s) for s in labels])
        judge = cls(classes, feats.mean(0), feats.std(0).clamp_min(1e-6), None, None)
        z = judge.standardize(feats).double()
        w = torch.zeros(z.shape[1], len(classes), dtype=torch.float64, requires_grad=True)
        b = torch.zeros(len(classes), dtype=torch.float64, requires_grad=True)
        opt = torch.optim.LBFGS([w, b], max_iter=iterations, line_search_fn="strong_wolfe")

        def closure():
            opt.zero_grad()
            loss = torch.nn.functional.cross_entropy(z @ w + b, y) + weight_decay * (w ** 2).sum()
            loss.backward()
            return loss

        opt.step(closure)
        judge.weight, judge.bias = w.detach().float(), b.detach().float()
        return judge

    def standardize(self, feats: torch.Tensor) -> torch.Tensor:
        return (feats - self.mean) / self.std

    def predict(self, feats: torch.Tensor) -> list[str]:
        """Style names read in ``feats (N, F)``."""
        return [self.classes[i] for i in (self.standardize(feats) @ self.weight + self.bias).argmax(-1).tolist()]


@functools.lru_cache(maxsize=2)
def train_judge(data_dir: Path) -> tuple[HandJudge, dict[tuple[str, str], torch.Tensor]]:
    """The judge fitted on the cache's train split (both datasets, mirrored copies included), and the mean
    standardised features of each (content, style) cell of that split (the targets of ``judge_toward``)."""
    data = MotionDataset(data_dir, "train")
    feats = torch.stack([judge_features(data.clip(i, normalized=False)) for i in range(len(data))])
    labels = [r.style for r in data.records]
    judge = HandJudge.fit(feats, labels)
    z = judge.standardize(feats)
    cells: dict[tuple[str, str], list[int]] = {}
    for i, r in enumerate(data.records):
        cells.setdefault((r.content, r.style), []).append(i)
    return judge, {k: z[v].mean(0) for k, v in cells.items()}


def judge_scores(data_dir: Path, contents_raw: Sequence[torch.Tensor], outputs_raw: Sequence[torch.Tensor],
                 content_labels: Sequence[str], target_styles: Sequence[str]) -> dict:
    """``{"judge_sra", "judge_toward", "judge_by_style": {style: (sra, toward)}}`` of outputs against their contents
    (raw features ``(T, D)`` each), see the module doc."""
    judge, centres = train_judge(Path(data_dir))
    f_out = torch.stack([judge_features(x) for x in outputs_raw])
    f_in = torch.stack([judge_features(x) for x in contents_raw])
    read = judge.predict(f_out)
    hit = torch.tensor([r == t for r, t in zip(read, target_styles)])
    centre = torch.stack([centres[(c, t)] for c, t in zip(content_labels, target_styles)])
    d_out = (judge.standardize(f_out) - centre).norm(dim=-1)
    toward = d_out < (1 - TOWARD_MARGIN) * (judge.standardize(f_in) - centre).norm(dim=-1)
    by_style = {}
    for s in sorted(set(target_styles)):
        idx = [i for i, t in enumerate(target_styles) if t == s]
        by_style[s] = (float(hit[idx].float().mean()), float(toward[idx].float().mean()))
    return {"judge_sra": float(hit.float().mean()), "judge_toward": float(toward.float().mean()),
            "judge_by_style": by_style}
