"""Fixtures the tests share (helpers are in helpers.py)."""
from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
import torch

from tests.helpers import FakeStyle
from tests.synthetic_cache import write_synthetic_cache
from transfer.bundle import MethodBundle
from transfer.denoiser import Denoiser, DenoiserConfig
from transfer.motion_encoder import MotionEncoder, MotionEncoderConfig


class HashedText:
    """Deterministic unit vectors per text: a stand-in for the sentence encoder."""

    def encode(self, texts):
        out = []
        for t in texts:
            seed = int(hashlib.sha1(t.encode()).hexdigest()[:8], 16)
            v = torch.randn(384, generator=torch.Generator().manual_seed(seed))
            out.append(v / v.norm())
        return torch.stack(out)


@pytest.fixture(scope="module")
def toys(tmp_path_factory):
    torch.manual_seed(0)
    prior = Denoiser(DenoiserConfig(width=32, layers=2, heads=2, ff=64, dropout=0.0)).eval()
    encoder = MotionEncoder(MotionEncoderConfig(width=32, layers=1, heads=2, ff=64, dropout=0.0)).eval()
    for p in encoder.parameters():
        p.requires_grad_(False)
    cache = write_synthetic_cache(tmp_path_factory.mktemp("cache"))
    return MethodBundle(prior, motion_encoder=encoder, text_encoder=HashedText()), cache


@pytest.fixture
def fake_pipeline(monkeypatch):
    """learn/apply replaced by fakes that write the files the real ones write; calls are recorded."""
    calls = {"learn": [], "apply": [], "crash_after_bvh": set()}

    def learn_file(video, out, **kw):
        calls["learn"].append(Path(video).name)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text("style")

    def load(path):
        if Path(path).read_text() != "style":
            raise ValueError(f"{path}: not a style file")
        return FakeStyle()

    def apply(self, clip, out_dir, request, joint_map=None):
        from video2style.result import ApplyResult

        calls["apply"].append(str(clip))
        calls.setdefault("apply_args", []).append((request.strength, request.seed, request.neutralize, joint_map,
                                                   request.preview, request.tempo, request.feet))
        out_dir.mkdir(parents=True, exist_ok=True)
        bvh = out_dir / f"{clip.stem}.bvh"
        bvh.write_text("bvh")
        if clip.name in calls["crash_after_bvh"]:
            raise KeyboardInterrupt  # killed between the BVH and its preview
        preview = out_dir / f"{clip.stem}_preview.mp4"
        preview.write_text("mp4")
        return ApplyResult(str(clip), [str(bvh)], preview=str(preview))

    monkeypatch.setattr("video2style.pipeline.learn_file", learn_file)
    monkeypatch.setattr("video2style.loaded_style.LoadedStyle.apply", apply)
    monkeypatch.setattr("transfer.bundle.load_models", lambda device="cpu": type("M", (), {"prior": None})())
    monkeypatch.setattr("transfer.style_file.Style.load", staticmethod(load))
    monkeypatch.setattr("transfer.style_file.style_model", lambda prior, style: None)
    return calls
