"""The motion dataset cache: Bandai-Namco clips on the canonical skeleton as model features.

``build_dataset`` reads the ``.tar.xz`` archives directly, resamples to the canonical fps,
retargets, mirrors (swapping left/right labels), encodes, splits (seeded, stratified by
content x style; a clip and its mirror share a split) and writes:

- ``features.safetensors``: ``features (N, D)`` float32, all clips back to back; ``mean``/``std`` (D,) over train
- ``clips.json``: one record per clip (name, dataset, content, style, caption, split, mirrored, start, length)
- ``split.json``: clip names per split, the seed and the rule
"""
from __future__ import annotations

import json
import random
import re
import tarfile
import time
from collections import defaultdict
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from safetensors.torch import load_file, save_file
from tqdm import tqdm

from mlcore.captions import (
    BANDAI2_CONTENTS,
    MIRROR_CONTENT,
    NEUTRAL_STYLE,
    STYLE_ALIASES,
    STYLES,
    caption,
)
from motioncore.bvh import BvhError, parse_bvh
from motioncore.files import atomic_output, atomic_write_text
from motioncore.ik_fit import conform_rolls
from motioncore.motion import mirror, resample
from motioncore.representation import FEATURES, encode
from motioncore.retarget import make_rig, place_on_floor, to_canonical
from motioncore.skeleton import CANONICAL

_NAME = re.compile(r"dataset-(\d)_(?P<content>[a-z-]+?)_(?P<style>[a-z]+)_(?P<num>\d+)\.bvh$")
STD_FLOOR = 1e-2
LABELS = {"content": BANDAI2_CONTENTS, "style": STYLES}  # a clip's labels and their classes (classifiers, Park et al.)


@dataclass
class ClipRecord:
    name: str
    dataset: str
    content: str
    style: str
    caption: str
    split: str
    mirrored: bool
    start: int
    length: int


def _iter_archive(path: Path):
    """Yield ``(member name, bvh text)`` for every BVH in a ``.tar.xz``, streaming."""
    with tarfile.open(path, mode="r:*") as tar:
        for member in tar:
            if member.isfile() and member.name.endswith(".bvh"):
                f = tar.extractfile(member)
                if f is not None:
                    yield member.name, f.read().decode("utf-8", errors="replace")


def canonical_features(text: str, name: str, fps: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Raw features ``(T, D)`` of a Bandai BVH's text on the canonical skeleton at ``fps`` (rolls conformed, on the
    floor), and of its mirrored copy."""
    motion, _ = parse_bvh(text, name)
    motion = resample(motion, fps)
    rig = make_rig(motion.skeleton, motion, source=name)
    canon = place_on_floor(conform_rolls(to_canonical(motion, rig)))
    return encode(canon), encode(mirror(canon))


def _assign_splits(keys: list[tuple[str, str, str]], seed: int, n_test: int, n_val: int) -> dict[str, str]:
    """keys: (clip name, dataset, content x style cell). Per cell of dataset 2: n_test test, n_val val."""
    rng = random.Random(seed)
    cells: dict[tuple[str, str], list[str]] = defaultdict(list)
    for name, ds, cell in sorted(keys):
        cells[(ds, cell)].append(name)
    split = {}
    for (ds, _), names in sorted(cells.items()):
        rng.shuffle(names)
        k_test, k_val = (n_test, n_val) if ds == "bandai2" and len(names) > n_test + n_val else (0, 0)
        for i, n in enumerate(names):
            split[n] = "test" if i < k_test else "val" if i < k_test + k_val else "train"
    return split


def build_dataset(
    archives: list[Path],
    out_dir: Path,
    fps: float = CANONICAL.fps,
    seed: int = 0,
    n_test: int = 6,
    n_val: int = 3,
    progress: bool = True,
) -> dict:
    """Build the cache in ``out_dir`` from Bandai ``.tar.xz`` archives; returns a summary dict."""
    t0 = time.time()
    items = []  # (name, dataset, content, style, feats, feats_mirrored)
    failed = []
    for archive in archives:
        archive = Path(archive)
        if not archive.is_file():
            raise FileNotFoundError(f"{archive}: no such archive")
        bar = tqdm(_iter_archive(archive), desc=archive.name, unit="clip", disable=not progress)
        for member, text in bar:
            m = _NAME.search(member)
            if m is None:
                continue
            try:
                f, fm = canonical_features(text, member, fps)
            except (BvhError, ValueError) as e:
                failed.append(f"{member}: {e}")
                continue
            ds = f"bandai{m.group(1)}"
            style = STYLE_ALIASES.get(m.group("style"), m.group("style"))
            items.append((Path(member).stem, ds, m.group("content"), style, f, fm))
    if not items:
        raise ValueError(f"no Bandai clips found in {', '.join(map(str, archives))}")
    split = _assign_splits([(n, ds, f"{c}|{s}") for n, ds, c, s, _, _ in items], seed, n_test, n_val)

    records, chunks, start = [], [], 0
    for name, ds, content, style, f, fm in items:
        for mirrored, feats in ((False, f), (True, fm)):
            c = MIRROR_CONTENT.get(content, content) if mirrored else content
            rec = ClipRecord(name + ("_mirror" if mirrored else ""), ds, c, style, caption(c, style), split[name], mirrored, start, feats.shape[0])
            records.append(rec)
            chunks.append(feats)
            start += feats.shape[0]
    features = torch.cat(chunks)
    train_rows = torch.cat([torch.arange(r.start, r.start + r.length) for r in records if r.split == "train"])
    mean = features[train_rows].mean(0)
    std = features[train_rows].std(0).clamp_min(STD_FLOOR)

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_output(out_dir / "features.safetensors", ".tmp") as tmp:
        save_file({"features": features.contiguous(), "mean": mean, "std": std}, str(tmp),
                  metadata={"fps": str(fps), "dim": str(FEATURES.dim), "joints": ",".join(CANONICAL.skeleton.names)})
    atomic_write_text(out_dir / "clips.json", json.dumps([asdict(r) for r in records], indent=0))
    by_split = defaultdict(list)
    for n in sorted(split):
        by_split[split[n]].append(n)
    atomic_write_text(out_dir / "split.json", json.dumps(
        {"seed": seed, "rule": f"bandai2: per content x style cell, {n_test} test and {n_val} val clips, rest train; "
         "bandai1: all train; mirrored copies share their clip's split", **by_split}, indent=1))
    summary = {"clips": len(records), "failed": failed, "seconds": time.time() - t0, "splits": {}}
    for s in ("train", "val", "test"):
        rs = [r for r in records if r.split == s]
        summary["splits"][s] = {"clips": len(rs), "frames": sum(r.length for r in rs), "hours": sum(r.length for r in rs) / fps / 3600}
    return summary


class MotionDataset:
    """The cache loaded for training: normalised features and clip records of one split."""

    def __init__(self, cache_dir: Path, split: str | None = "train", exclude_styles: tuple[str, ...] = ()):
        """``exclude_styles``: drop every clip of these styles (Bandai-1 aliases count as their Bandai-2 names),
        for models trained without them (the unseen-style protocol). The feature statistics stay the cache's."""
        cache_dir = Path(cache_dir)
        unknown = sorted(set(exclude_styles) - set(STYLES))
        if unknown:
            raise ValueError(f"MotionDataset: expected styles among {', '.join(STYLES)}, got {', '.join(unknown)}")
        if NEUTRAL_STYLE in exclude_styles:
            raise ValueError(f"MotionDataset: the neutral style {NEUTRAL_STYLE!r} cannot be excluded")
        path = cache_dir / "features.safetensors"
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no dataset cache; run `video2style dataset` first")
        data = load_file(str(path))
        self.features, self.mean, self.std = data["features"], data["mean"], data["std"]
        records = [ClipRecord(**r) for r in json.loads((cache_dir / "clips.json").read_text())]
        self.records = [r for r in records if (split is None or r.split == split) and r.style not in exclude_styles]

    def __len__(self) -> int:
        return len(self.records)

    def clip(self, i: int, normalized: bool = True) -> torch.Tensor:
        """Features ``(T, D)`` of clip ``i``."""
        r = self.records[i]
        x = self.features[r.start:r.start + r.length]
        return (x - self.mean) / self.std if normalized else x

    def standardize(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std

    def denormalize(self, x: torch.Tensor) -> torch.Tensor:
        return x * self.std + self.mean

    def sample_windows(self, n: int, window: int, generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor, list[int]]:
        """``n`` random clips, each a random window of up to ``window`` frames, normalised and zero-padded.

        Returns ``x (n, window, D)``, ``valid (n, window)`` bool, and the clip indices.
        """
        idx = torch.randint(len(self.records), (n,), generator=generator).tolist()
        x = torch.zeros(n, window, self.features.shape[1])
        valid = torch.zeros(n, window, dtype=torch.bool)
        for b, i in enumerate(idx):
            r = self.records[i]
            length = min(window, r.length)
            s = int(torch.randint(r.length - length + 1, (1,), generator=generator))
            x[b, :length] = self.standardize(self.features[r.start + s:r.start + s + length])
            valid[b, :length] = True
        return x, valid, idx


def labelled_clips(data_dir: Path, split: str, target: str, originals_only: bool = False) -> tuple[MotionDataset, list[int], list[int]]:
    """Bandai-2 clips of ``split``: the dataset, clip indices into it, and class indices for ``target`` (a key of
    :data:`LABELS`); ``originals_only``: without the mirrored copies."""
    data = MotionDataset(data_dir, split)
    classes = list(LABELS[target])
    idx, labels = [], []
    for i, r in enumerate(data.records):
        value = getattr(r, target)
        if r.dataset == "bandai2" and value in classes and not (originals_only and r.mirrored):
            idx.append(i)
            labels.append(classes.index(value))
    return data, idx, labels
