"""Helpers the tests share (fixtures are in conftest.py): toy models and styles, BVH clips, fake learn/apply, Blender's
availability."""
from __future__ import annotations

import functools
import subprocess
import threading
from pathlib import Path

import pytest
import torch

from evaluation.classifiers import ClassifierConfig, MotionClassifier
from mlcore.checkpoints import save_model
from motioncore.bvh import BvhLayout, write_bvh
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion
from transfer.denoiser import Denoiser, DenoiserConfig
from transfer.lora import LoRALinear, add_lora, lora_state
from transfer.style_config import LearnConfig
from transfer.style_file import Style
from video2style import interchange
from video2style.interchange import blender_command


def tiny_denoiser(seed=0):
    torch.manual_seed(seed)
    return Denoiser(DenoiserConfig(width=32, layers=2, heads=2, ff=64, dropout=0.0)).eval()


def trained_style(prior):
    import copy

    model = copy.deepcopy(prior)
    add_lora(model, rank=8)
    for m in model.modules():
        if isinstance(m, LoRALinear):
            torch.nn.init.normal_(m.lora_b, std=0.5)
    return Style(lora_state(model), {"rank": 8})


def toy_learn_config(**kw):
    return LearnConfig(iterations=4, pair_ddim_steps=3, transfer_ddim_steps=2, content_batch=2, window=24, **kw)


def snapshot_tree(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` with its bytes (None for folders and links): what a refused run must leave alone."""
    out = {}
    for p in sorted(root.rglob("*")):
        out[str(p.relative_to(root))] = p.read_bytes() if p.is_file() and not p.is_symlink() else None
    return out


def fake_apply(monkeypatch, gate: threading.Event | None = None, started: threading.Event | None = None):
    """apply's style loading and work replaced: each result names the style file it came from."""
    def load(path):
        s = FakeStyle()
        s.meta = {"style": Path(path).name}
        return s

    def apply(self, clip, out_dir, request, joint_map=None):
        from video2style.result import ApplyResult

        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / f"{clip.stem}.bvh").write_text(self.style.meta["style"])
        if started is not None:
            started.set()
            gate.wait(30)
        (out_dir / f"{clip.stem}_preview.mp4").write_text(self.style.meta["style"])
        return ApplyResult(str(clip), [str(out_dir / f"{clip.stem}.bvh")], frames=20, seconds_transfer=0.0)

    monkeypatch.setattr("video2style.loaded_style.LoadedStyle.apply", apply)
    monkeypatch.setattr("transfer.bundle.load_models", lambda device="cpu": type("M", (), {"prior": None})())
    monkeypatch.setattr("transfer.style_file.Style.load", staticmethod(load))
    monkeypatch.setattr("transfer.style_file.style_model", lambda prior, style: None)


def write_clip(path: Path, seconds: float = 1.0) -> Path:
    write_bvh(path, random_motion(seconds=seconds), BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    return path


class FakeStyle:
    def __init__(self):
        self.meta = {}
        self.source = None


def make_library(tmp_path: Path) -> tuple[Path, Path]:
    videos, content = tmp_path / "videos", tmp_path / "content"
    videos.mkdir()
    for name in ("old.mp4", "old.mov", "strut.mp4"):
        (videos / name).write_bytes(b"not read by the fake learner")
    for rel in ("a/walk.bvh", "b/walk.bvh", "run.bvh"):
        (content / rel).parent.mkdir(parents=True, exist_ok=True)
        (content / rel).write_text("clip")
    return videos, content


@functools.lru_cache(maxsize=1)
def blender_problem() -> str | None:
    cmd = blender_command()
    if cmd is None:
        return "neither the bpy module nor a `blender` on PATH (pip install \"video2style[fbx]\" or apt install blender python3-numpy)"
    if "--python" in cmd:  # blender -b: its own Python must have numpy
        probe, env = [cmd[0], "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", "import numpy"], \
            interchange.blender_env()
    else:
        probe, env = [cmd[0], "-c", "import bpy, numpy"], None
    proc = subprocess.run(probe, check=False, capture_output=True, text=True, timeout=120, env=env)
    if proc.returncode != 0:
        return "Blender's Python lacks numpy, which its FBX/glTF add-ons need (apt install python3-numpy)"
    return None


needs_blender = pytest.mark.skipif(blender_problem() is not None, reason=f"no usable Blender: {blender_problem()}")


def random_classifier(path: Path, target: str, classes: list[str]) -> Path:
    torch.manual_seed(len(classes))
    model = MotionClassifier(ClassifierConfig(target=target, classes=classes, channels=[8, 8], strides=[2, 1]))
    save_model(model.eval(), model.config, path)
    return path
