"""The learn -> apply path end to end with the shipped weights on the project-made samples (short settings)."""
from __future__ import annotations

from pathlib import Path

import pytest
import torch

from motioncore.bvh import read_bvh
from transfer.style import Style, StyleConfig, style_model
from video2style.demo import SAMPLES
from video2style.pipeline import WEIGHTS, apply_file, learn_file, load_models

pytestmark = pytest.mark.skipif(not (WEIGHTS / "denoiser.safetensors").is_file(), reason="shipped weights not present")


@pytest.fixture(autouse=True)
def one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def test_learn_from_a_bvh_and_apply_to_another(tmp_path, monkeypatch):
    monkeypatch.setenv("VIDEO2STYLE_DATA", str(tmp_path / "no-cache"))  # use the bundled content bank
    lines = []
    config = StyleConfig(iterations=2, pair_steps=3, max_seconds=30)
    summary = learn_file(SAMPLES / "walk_prior.bvh", tmp_path / "old.v2s", "old", None, config, progress=lines.append)
    assert summary["iterations"] == 2 and summary["bytes"] < 1024 * 1024
    assert any("content bank" in line for line in lines) and any("retrieval" in line for line in lines)
    style = Style.load(tmp_path / "old.v2s")
    assert style.meta["style"] == "old" and style.example is not None
    model = style_model(load_models().prior, style)
    info = apply_file(style, model, SAMPLES / "run_prior.bvh", tmp_path / "out", 300, preview=False, neutralize="never")
    out, _ = read_bvh(Path(info["output"]))
    src, _ = read_bvh(SAMPLES / "run_prior.bvh")
    assert out.skeleton.names == src.skeleton.names and out.num_frames == src.num_frames and out.fps == src.fps
    assert 0.0 <= info["skating_after"] <= info["skating_before"] + 1e-6
    assert torch.isfinite(out.lrot).all()
