"""A tiny dataset cache written directly (no archives), for tests of the classifiers and the evaluation protocol."""
from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import torch
from safetensors.torch import save_file

from mlcore.captions import caption
from mlcore.dataset import STD_FLOOR, ClipRecord
from motioncore.representation import encode
from testkit.motions import random_motion


def write_synthetic_cache(out_dir: Path, contents=("walk", "wave-left-hand"), styles=("normal", "elderly"),
                          per_split=(("test", 6), ("val", 1), ("train", 3)), seed: int = 0) -> Path:
    """Every content x style cell gets ``n`` originals per split, each followed by a 'mirrored' copy.

    Features are windows of a few encoded synthetic motions, so they decode to plausible bodies.
    """
    g = torch.Generator().manual_seed(seed)
    sources = [encode(random_motion(seconds=6, seed=seed + k)) for k in range(3)]
    records, chunks, start = [], [], 0
    k = 0
    for c in contents:
        for s in styles:
            for split, n in per_split:
                for i in range(n):
                    src = sources[k % len(sources)]
                    k += 1
                    length = int(torch.randint(25, 50, (1,), generator=g))
                    off = int(torch.randint(src.shape[0] - length, (1,), generator=g))
                    feats = src[off:off + length]
                    for mirrored in (False, True):
                        name = f"dataset-2_{c}_{s}_{split}{i:03d}" + ("_mirror" if mirrored else "")
                        records.append(ClipRecord(name, "bandai2", c, s, caption(c, s), split, mirrored, start, length))
                        chunks.append(feats)
                        start += length
    features = torch.cat(chunks)
    rows = torch.cat([torch.arange(r.start, r.start + r.length) for r in records if r.split == "train"])
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    save_file({"features": features.contiguous(), "mean": features[rows].mean(0),
               "std": features[rows].std(0).clamp_min(STD_FLOOR)}, str(out_dir / "features.safetensors"))
    (out_dir / "clips.json").write_text(json.dumps([asdict(r) for r in records]))
    return out_dir
