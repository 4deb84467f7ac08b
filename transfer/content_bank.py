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

from mlcore.captions import BANDAI2_CONTENTS, content_caption
from motioncore.files import atomic_output
from transfer.sampling import TEXT_TO_MOTION, TextToMotion

# The median length in frames (20 fps) of the prior's neutral training clips of each content (the dataset cache's
# Bandai-2 train split, unmirrored; docs/archive/RESULTS-notebook.md#the-content-bank-as-long-as-the-datas-clips):
# text-to-motion
# draws no content longer than the prior saw it (a run drawn at 80 frames lifts its feet 29.5 cm, at 57 39 cm).
DATA_FRAMES = {"raise-up-both-hands": 38, "raise-up-left-hand": 38, "raise-up-right-hand": 40, "run": 57, "walk": 174,
               "walk-turn-left": 106, "walk-turn-right": 110, "wave-both-hands": 135, "wave-left-hand": 136,
               "wave-right-hand": 141}


@dataclass
class BankRecord:
    caption: str
    content: str
    style: str
    length: int


class ContentBank:
    """The slice of :class:`mlcore.dataset.MotionDataset`'s interface that style learning uses."""

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
    (:class:`transfer.bundle.MethodBundle`, on its device) as ``settings`` say, each ``length`` frames or, where the
    prior's training clips of that content are shorter (:data:`DATA_FRAMES`), as long as those (zero-padded to
    ``length`` in the file, their records say how long); returns the number written."""
    gen = torch.Generator().manual_seed(seed)
    feats, records = [], []
    for content in BANDAI2_CONTENTS:
        frames = min(length, DATA_FRAMES.get(content, length))
        text = models.text_encoder.encode([content_caption(content)] * per_content)
        drawn = models.text_to_motion(text, frames, gen, settings)
        feats.append(torch.nn.functional.pad(drawn, (0, 0, 0, length - frames)))
        records += [{"caption": content_caption(content), "content": content, "style": "normal", "length": frames}] * per_content
    with atomic_output(out_path, ".tmp") as tmp:
        save_file({"features": torch.cat(feats).to("cpu", torch.float16).contiguous()}, str(tmp),
                  metadata={"records": json.dumps(records), "about": "samples of the video2style prior (project-made)"})
    return len(records)
