"""CLI paths of the second method (apply --method stgcn), pose errors and evaluate, on tiny project-made models."""
from __future__ import annotations

import pytest
import torch

from evaluation.park.networks import ParkConfig, ParkModel
from motioncore.bvh import BvhLayout, read_bvh, write_bvh
from motioncore.skeleton import CANONICAL
from tests.helpers import random_motion
from transfer.checkpoints import save_model
from video2style.cli import main


@pytest.fixture(scope="module")
def park_weights(tmp_path_factory):
    torch.manual_seed(0)
    model = ParkModel(ParkConfig(channels=[8, 16, 32], window=16)).eval()
    path = tmp_path_factory.mktemp("park") / "park.safetensors"
    save_model(model, model.config, path, {"licence": "test"})
    return path


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    path = tmp_path_factory.mktemp("clips") / "walk.bvh"
    write_bvh(path, random_motion(3.0, seed=2), BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    return path


def test_stgcn_variants_write_one_bvh_each_on_the_clip_skeleton(park_weights, clip, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["apply", "--method", "stgcn", "--domain", "elderly", "--variants", "3", "--weights", str(park_weights),
                 str(clip), "-o", str(out), "--no-preview"]) == 0
    files = sorted(p.name for p in out.glob("*.bvh"))
    assert files == ["walk_elderly-s0.bvh", "walk_elderly-s1.bvh", "walk_elderly-s2.bvh"]
    src, _ = read_bvh(clip)
    a, _ = read_bvh(out / files[0])
    b, _ = read_bvh(out / files[1])
    assert a.skeleton.names == src.skeleton.names and a.num_frames == src.num_frames
    assert not torch.allclose(a.lrot, b.lrot, atol=1e-4)  # distinct noise, distinct outputs


def test_stgcn_mix_and_reference(park_weights, clip, tmp_path):
    out = tmp_path / "mix"
    assert main(["apply", "--method", "stgcn", "--domain", "elderly", "--mix", "exhausted", "--mix-steps", "3",
                 "--weights", str(park_weights), str(clip), "-o", str(out), "--no-preview"]) == 0
    assert len(list(out.glob("*.bvh"))) == 3
    out = tmp_path / "ref"
    assert main(["apply", "--method", "stgcn", "--domain", "active", "--reference", str(clip),
                 "--weights", str(park_weights), str(clip), "-o", str(out)]) == 0
    assert (out / "walk.bvh").is_file() and (out / "walk_preview.mp4").is_file()


@pytest.mark.parametrize("argv, message", [
    (["--domain", "old"], "--domain: expected one of"),
    ([], "give --domain"),
    (["--domain", "elderly", "--mix", "nonsense"], "--mix: expected a domain"),
    (["--domain", "elderly", "--variants", "0"], "--variants: expected 1 to 64"),
    (["--domain", "elderly", "--variants", "100000"], "--variants: expected 1 to 64"),
    (["--domain", "elderly", "--mix", "exhausted", "--mix-steps", "100000"], "--mix-steps: expected 2 to 64"),
])
def test_stgcn_bad_requests_are_one_line_errors(park_weights, clip, tmp_path, capsys, argv, message):
    rc = main(["apply", "--method", "stgcn", *argv, "--weights", str(park_weights), str(clip), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and message in err and "\n" not in err
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").iterdir())


def test_diffusion_apply_rejects_stgcn_flags(tmp_path, clip, capsys):
    assert main(["apply", str(tmp_path / "x.v2s"), str(clip), "-o", str(tmp_path), "--domain", "elderly"]) == 1
    assert "--domain belongs to --method stgcn" in capsys.readouterr().err


def test_pose_of_a_non_video_names_the_file(tmp_path, capsys):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video at all")
    assert main(["pose", str(bad), "-o", str(tmp_path / "bad.bvh"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "bad.mp4" in err and not (tmp_path / "bad.bvh").exists()


def test_evaluate_identity_and_stgcn_on_a_tiny_cache(tmp_path, park_weights, monkeypatch):
    from tests.synthetic_cache import write_synthetic_cache
    from tests.test_evaluation import _random_classifier
    from transfer.captions import BANDAI2_CONTENTS, STYLES
    from video2style import park_apply as stgcn
    from video2style.evaluate import evaluate

    cache = write_synthetic_cache(tmp_path / "cache")
    weights = {"content": _random_classifier(tmp_path / "c.safetensors", "content", list(BANDAI2_CONTENTS)),
               "style": _random_classifier(tmp_path / "s.safetensors", "style", list(STYLES))}
    monkeypatch.setattr("evaluation.protocol.default_weights", lambda target: weights[target])
    stgcn.load_stylizer.cache_clear()
    monkeypatch.setattr(stgcn, "weights_path", lambda name: park_weights)
    lines = list(evaluate(cache, tmp_path / "eval", quick=True, methods=["identity", "stgcn"]))
    stgcn.load_stylizer.cache_clear()
    table = (tmp_path / "eval" / "table.md").read_text()
    assert "| identity |" in table and "| stgcn |" in table and lines[-1].startswith("wrote")
    assert (tmp_path / "eval" / "tradeoff.png").stat().st_size > 1000 and "target-style FMD" in table
    with pytest.raises(ValueError, match="unknown method"):
        list(evaluate(cache, tmp_path / "eval2", methods=["nope"]))
    with pytest.raises(FileNotFoundError, match="other_park.safetensors"):  # --stgcn-weights is used, not the default
        list(evaluate(cache, tmp_path / "eval3", methods=["stgcn"], stgcn_weights=tmp_path / "other_park.safetensors"))


def test_train_classifier_command_on_a_tiny_cache(tmp_path, capsys):
    from tests.synthetic_cache import write_synthetic_cache

    cache = write_synthetic_cache(tmp_path / "cache")
    weights = tmp_path / "style.safetensors"
    assert main(["train-classifier", "--target", "style", "--data", str(cache), "--out", str(tmp_path / "run"),
                 "--weights", str(weights), "--max-steps", "2", "-q"]) == 0
    assert weights.is_file() and "style classifier: step 2" in capsys.readouterr().out


def test_garbage_park_weights_are_one_line(tmp_path, clip, capsys):
    from video2style import park_apply as stgcn

    bad = tmp_path / "garbage.safetensors"
    bad.write_bytes(b"\x08\x00\x00\x00\x00\x00\x00\x00{}garbage")
    stgcn.load_stylizer.cache_clear()
    rc = main(["apply", "--method", "stgcn", "--domain", "elderly", "--weights", str(bad), str(clip), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and f"{bad}: not Park stylizer weights" in err and "\n" not in err


def test_training_commands_never_replace_the_shipped_weights_unless_named(tmp_path, capsys):
    """By default train-classifier exports into its run folder; the installed weights stay as they were."""
    import hashlib

    from evaluation.classifiers import default_weights
    from tests.synthetic_cache import write_synthetic_cache

    shipped = default_weights("style")
    before = hashlib.sha256(shipped.read_bytes()).hexdigest()
    cache = write_synthetic_cache(tmp_path / "cache")
    assert main(["train-classifier", "--target", "style", "--data", str(cache), "--out", str(tmp_path / "run"),
                 "--max-steps", "1", "-q"]) == 0
    assert (tmp_path / "run" / shipped.name).is_file()
    assert f"weights: {tmp_path / 'run' / shipped.name}" in capsys.readouterr().out
    assert hashlib.sha256(shipped.read_bytes()).hexdigest() == before
