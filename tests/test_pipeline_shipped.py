"""The learn -> apply path end to end with the shipped weights on the project-made samples (short settings)."""
from __future__ import annotations

from pathlib import Path

import pytest
import torch

from mlcore.shipped import SHIPPED as WEIGHTS
from motioncore.bvh import read_bvh
from transfer.style_config import LearnConfig
from transfer.style_file import Style
from video2style.demo import SAMPLES
from video2style.loaded_style import LoadedStyle
from video2style.options import ApplyOptions
from video2style.pipeline import PartialStyleError, learn_file

pytestmark = pytest.mark.skipif(not (WEIGHTS / "denoiser.safetensors").is_file(), reason="shipped weights not present")


@pytest.fixture(autouse=True)
def one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.mark.slow
def test_learn_from_a_bvh_and_apply_to_another(tmp_path, monkeypatch):
    monkeypatch.setenv("VIDEO2STYLE_DATA", str(tmp_path / "no-cache"))  # use the bundled content bank
    lines = []
    config = LearnConfig(iterations=2, pair_ddim_steps=3)
    with pytest.raises(PartialStyleError, match="only 2 fine-tuning iterations"):  # too few to show: refused
        learn_file(SAMPLES / "walk_prior.bvh", tmp_path / "old.v2s", "old", None, config, progress=lines.append)
    assert not (tmp_path / "old.v2s").exists()
    summary = learn_file(SAMPLES / "walk_prior.bvh", tmp_path / "old.v2s", "old", None, config, progress=lines.append,
                         allow_partial=True)
    assert summary["iterations"] == 2 and summary["bytes"] < 1024 * 1024 and "only 2" in summary["partial"]
    assert any("content bank" in line for line in lines) and any("retrieval" in line for line in lines)
    style = Style.load(tmp_path / "old.v2s")
    assert style.meta["style"] == "old" and style.example is not None
    assert style.meta["iterations"] == 2 and len(style.meta["loss_rec"]) == 2 and style.meta["partial"]
    info = LoadedStyle.from_style(style).apply(SAMPLES / "run_prior.bvh", tmp_path / "out",
                                               ApplyOptions(strength=0.5, preview=False, neutralize="never"))
    out, _ = read_bvh(Path(info.output))
    src, _ = read_bvh(SAMPLES / "run_prior.bvh")
    assert out.skeleton.names == src.skeleton.names and out.num_frames == src.num_frames and out.fps == src.fps
    assert 0.0 <= info.skating_after <= info.skating_before + 1e-6
    from motioncore.skating import foot_skating_ratio
    from video2style.pipeline import read_clip

    content = read_clip(SAMPLES / "run_prior.bvh").canonical  # what it passes on, said beside the result's
    assert info.skating_content == foot_skating_ratio(content.global_positions(), content.fps)
    assert torch.isfinite(out.lrot).all()


@pytest.mark.slow
def test_learn_command_refuses_a_partial_style_in_one_line(tmp_path, monkeypatch, capsys):
    from video2style.cli import main

    monkeypatch.setenv("VIDEO2STYLE_DATA", str(tmp_path / "no-cache"))
    out = tmp_path / "old.v2s"
    argv = ["learn", str(SAMPLES / "walk_prior.bvh"), "--style", "old", "-o", str(out), "--iterations", "3"]
    assert main(argv) == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and "it/s" not in ln and "%|" not in ln]
    assert len(err) == 1 and "only 3 fine-tuning iterations" in err[0] and "--allow-partial" in err[0]
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))
    # a time cap that cuts learning short is said too, and --allow-partial keeps the file with a warning
    assert main([*argv[:-2], "--max-seconds", "0.001", "--allow-partial"]) == 0
    assert "cut short by the time cap" in capsys.readouterr().err and Style.load(out).meta["stopped_by"] == "time"
    assert main(["learn", str(SAMPLES / "walk_prior.bvh"), "-o", str(out), "--start", "3", "--end", "1"]) == 1
    assert "must be after --start" in capsys.readouterr().err


def test_a_style_from_another_prior_is_warned_about(tmp_path):
    from transfer.bundle import base_model_warning

    style = Style({}, {"base_model_sha256": "0" * 64})
    assert "learned on another prior" in base_model_warning(style, Path("x.v2s"))
    style.meta["base_model_sha256"] = None
    assert base_model_warning(style, Path("x.v2s")) is None
