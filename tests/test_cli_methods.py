"""CLI paths of the second method (apply --method park), pose errors and evaluate, on tiny project-made models."""
from __future__ import annotations

import json

import pytest
import torch

from mlcore.checkpoints import save_model
from motioncore.bvh import BvhLayout, read_bvh, write_bvh
from motioncore.skeleton import CANONICAL
from park.networks import ParkConfig, ParkModel
from testkit.motions import random_motion
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


def test_park_variants_write_one_bvh_each_on_the_clip_skeleton(park_weights, clip, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["apply", "--method", "park", "--domain", "elderly", "--variants", "3", "--park-weights", str(park_weights),
                 str(clip), "-o", str(out), "--no-preview"]) == 0
    files = sorted(p.name for p in out.glob("*.bvh"))
    assert files == ["walk_elderly-s0.bvh", "walk_elderly-s1.bvh", "walk_elderly-s2.bvh"]
    src, _ = read_bvh(clip)
    a, _ = read_bvh(out / files[0])
    b, _ = read_bvh(out / files[1])
    assert a.skeleton.names == src.skeleton.names and a.num_frames == src.num_frames
    assert not torch.allclose(a.lrot, b.lrot, atol=1e-4)  # distinct noise, distinct outputs


@pytest.mark.slow
def test_park_mix_and_reference(park_weights, clip, tmp_path):
    out = tmp_path / "mix"
    assert main(["apply", "--method", "park", "--domain", "elderly", "--mix", "exhausted", "--mix-steps", "3",
                 "--park-weights", str(park_weights), str(clip), "-o", str(out), "--no-preview"]) == 0
    assert len(list(out.glob("*.bvh"))) == 3
    out = tmp_path / "ref"
    assert main(["apply", "--method", "park", "--domain", "active", "--reference", str(clip),
                 "--park-weights", str(park_weights), str(clip), "-o", str(out)]) == 0
    assert (out / "walk.bvh").is_file() and (out / "walk_preview.mp4").is_file()


@pytest.mark.parametrize("argv, message", [
    (["--domain", "old"], "--domain: expected one of"),
    ([], "give --domain"),
    (["--domain", "elderly", "--mix", "nonsense"], "--mix: expected a domain"),
    (["--domain", "elderly", "--variants", "0"], "--variants: expected 1 to 64"),
    (["--domain", "elderly", "--variants", "100000"], "--variants: expected 1 to 64"),
    (["--domain", "elderly", "--mix", "exhausted", "--mix-steps", "100000"], "--mix-steps: expected 2 to 64"),
])
def test_park_bad_requests_are_one_line_errors(park_weights, clip, tmp_path, capsys, argv, message):
    rc = main(["apply", "--method", "park", *argv, "--park-weights", str(park_weights), str(clip), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and message in err and "\n" not in err
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").iterdir())


def test_the_older_names_stgcn_and_weights_give_the_same_files(park_weights, clip, tmp_path):
    """``--method stgcn`` and ``--weights`` are the older names of ``--method park`` and ``--park-weights``."""
    runs = {"new": ["--method", "park", "--park-weights"], "old": ["--method", "stgcn", "--weights"]}
    for name, (m, method, w) in runs.items():
        assert main(["apply", m, method, "--domain", "elderly", "--mix", "exhausted", "--mix-steps", "2", w,
                     str(park_weights), str(clip), "-o", str(tmp_path / name), "--no-preview"]) == 0
    files = sorted(p.name for p in (tmp_path / "new").glob("*.bvh"))
    assert len(files) == 2 and files == sorted(p.name for p in (tmp_path / "old").glob("*.bvh"))
    for f in files:
        assert (tmp_path / "new" / f).read_bytes() == (tmp_path / "old" / f).read_bytes()


def test_the_mix_interpolates_codes_with_park_infer_mix(park_weights):
    """apply --mix's codes are :func:`park.infer.mixed_code` of the two ends, as :func:`park.infer.mix` uses."""
    from park.infer import code_from_noise, generate, mix
    from video2style.park_apply import ParkRequest, park_model, style_codes

    park_model.cache_clear()
    model = park_model(park_weights)
    codes = style_codes(model, ParkRequest("elderly", seed=3, mix="exhausted", mix_steps=3))
    a, b = code_from_noise(model, "elderly", 3)[0], code_from_noise(model, "exhausted", 3)[0]
    assert [tag for _, tag in codes] == ["elderly-exhausted-0.00", "elderly-exhausted-0.50", "elderly-exhausted-1.00"]
    content = torch.randn(20, model.config.feature_dim)
    for (code, _), alpha in zip(codes, (0.0, 0.5, 1.0)):
        assert torch.equal(generate(model, content, code), mix(model, content, a, b, alpha))
    park_model.cache_clear()


def test_diffusion_apply_rejects_park_flags(tmp_path, clip, capsys):
    assert main(["apply", str(tmp_path / "x.v2s"), str(clip), "-o", str(tmp_path), "--domain", "elderly"]) == 1
    assert "--domain belongs to --method park" in capsys.readouterr().err


def test_pose_of_a_non_video_names_the_file(tmp_path, capsys):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video at all")
    assert main(["pose", str(bad), "-o", str(tmp_path / "bad.bvh"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "bad.mp4" in err and not (tmp_path / "bad.bvh").exists()


@pytest.mark.slow
def test_evaluate_identity_and_park_on_a_tiny_cache(tmp_path, park_weights, monkeypatch):
    from mlcore.captions import BANDAI2_CONTENTS, STYLES
    from tests.helpers import random_classifier
    from tests.synthetic_cache import write_synthetic_cache
    from video2style import park_apply
    from video2style.evaluate import evaluate

    cache = write_synthetic_cache(tmp_path / "cache")
    weights = {"content": random_classifier(tmp_path / "c.safetensors", "content", list(BANDAI2_CONTENTS)),
               "style": random_classifier(tmp_path / "s.safetensors", "style", list(STYLES))}
    monkeypatch.setattr("evaluation.protocol.default_weights", lambda target: weights[target])
    park_apply.park_model.cache_clear()
    monkeypatch.setattr(park_apply, "weights_path", lambda name: park_weights)
    lines = list(evaluate(cache, tmp_path / "eval", quick=True, methods=["identity", "park"]))
    table = (tmp_path / "eval" / "table.md").read_text()
    assert "| identity |" in table and "| park |" in table and lines[-1].startswith("wrote")
    # the older name stgcn runs as park, with the same numbers, in a row named park
    list(evaluate(cache, tmp_path / "eval_old", quick=True, methods=["identity", "stgcn", "park"]))
    park_apply.park_model.cache_clear()
    rows, old = ([{k: v for k, v in r.items() if k not in ("sec_per_transfer", "seconds")}
                  for r in json.loads((tmp_path / d / "rows.json").read_text())] for d in ("eval", "eval_old"))
    assert [r["method"] for r in old] == [r["method"] for r in rows] and old == rows
    assert (tmp_path / "eval" / "tradeoff.png").stat().st_size > 1000 and "target-style FMD" in table
    with pytest.raises(ValueError, match="unknown method"):
        list(evaluate(cache, tmp_path / "eval2", methods=["nope"]))
    with pytest.raises(FileNotFoundError, match="other_park.safetensors"):  # --park-weights is used, not the default
        list(evaluate(cache, tmp_path / "eval3", methods=["park"], park_weights=tmp_path / "other_park.safetensors"))


def test_evaluate_takes_the_older_names_of_methods_and_weights():
    from transfer.style_config import split_config
    from video2style.cli import build_parser
    from video2style.methods import ALIASES, METHODS, VARIANTS, method_names

    args = build_parser().parse_args(["evaluate", "--stgcn-weights", "w.safetensors"])
    assert str(args.park_weights) == "w.safetensors" and args.methods == ["identity", "park", "ours"]
    assert method_names(["identity", "stgcn", "stgcn-raw", "ours-diff", "ours"]) == ["identity", "park", "park-raw", "ours"]
    assert all(target in METHODS and alias not in METHODS for alias, target in ALIASES.items())
    configs = {name: split_config(settings) for name, settings in VARIANTS.items()}
    assert len({repr(c) for c in configs.values()}) == len(configs)  # no two variants alike


@pytest.mark.slow
def test_train_classifier_command_on_a_tiny_cache(tmp_path, capsys):
    from tests.synthetic_cache import write_synthetic_cache

    cache = write_synthetic_cache(tmp_path / "cache")
    weights = tmp_path / "style.safetensors"
    assert main(["train-classifier", "--target", "style", "--data", str(cache), "--out", str(tmp_path / "run"),
                 "--weights", str(weights), "--max-steps", "2", "-q"]) == 0
    assert weights.is_file() and "style classifier: step 2" in capsys.readouterr().out


def test_garbage_park_weights_are_one_line(tmp_path, clip, capsys):
    from video2style import park_apply

    bad = tmp_path / "garbage.safetensors"
    bad.write_bytes(b"\x08\x00\x00\x00\x00\x00\x00\x00{}garbage")
    park_apply.park_model.cache_clear()
    rc = main(["apply", "--method", "park", "--domain", "elderly", "--park-weights", str(bad), str(clip), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and f"{bad}: not Park stylizer weights" in err and "\n" not in err


@pytest.mark.slow
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
