"""Neutral content motions sampled from the project's own prior, shipped with the weights.

Style learning's semantic loss needs a variety of neutral content motions. With the dataset
cache present, its "normal" clips are used; without it (a fresh install), this bank stands in:
the prior's samples for each neutral content caption, stored as normalised features.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import load_file, save_file

from motioncore.files import atomic_output
from transfer.captions import BANDAI2_CONTENTS, content_caption
from transfer.sampling import TEXT_TO_MOTION, TextToMotion


@dataclass
class BankRecord:
    caption: str
    content: str
    style: str
    length: int


class ContentBank:
    """The slice of :class:`transfer.dataset.MotionDataset`'s interface that style learning uses."""

    def __init__(self, path: Path):
        path = Path(path)
        tensors = load_file(str(path))
        with safe_open(str(path), framework="pt") as f:
            meta = json.loads(f.metadata()["records"])
        self.features = tensors["features"].float()  # (N, T, D) normalised
        self.records = [BankRecord(**r) for r in meta]

    def __len__(self) -> int:
        return len(self.records)

    def clip(self, i: int) -> torch.Tensor:
        return self.features[i, : self.records[i].length]


@torch.no_grad()
def make_content_bank(models, out_path: Path, per_content: int = 4, length: int = 80, seed: int = 0,
                      settings: TextToMotion = TEXT_TO_MOTION) -> int:
    """Sample ``per_content`` neutral clips for each Bandai-2 content with the prior of ``models``
    (:class:`transfer.bundle.MethodBundle`, on its device) as ``settings`` say; returns the number written."""
    gen = torch.Generator().manual_seed(seed)
    feats, records = [], []
    for content in BANDAI2_CONTENTS:
        text = models.text_encoder.encode([content_caption(content)] * per_content)
        feats.append(models.text_to_motion(text, length, gen, settings))
        records += [{"caption": content_caption(content), "content": content, "style": "normal", "length": length}] * per_content
    with atomic_output(out_path, ".tmp") as tmp:
        save_file({"features": torch.cat(feats).to("cpu", torch.float16).contiguous()}, str(tmp),
                  metadata={"records": json.dumps(records), "about": "samples of the video2style prior (project-made)"})
    return len(records)
