"""Style files are untrusted: crafted metadata and tensors give one line naming the file and the field."""
from __future__ import annotations

import json

import pytest
import torch
from safetensors.torch import save_file

from motioncore.representation import FEATURES
from tests.helpers import tiny_denoiser, trained_style
from transfer.style_file import Style, style_model


def _write(path, meta, tensors):
    save_file({k: v.contiguous() for k, v in tensors.items()}, str(path),
              metadata={"video2style": meta if isinstance(meta, str) else json.dumps(meta)})
    return path


@pytest.fixture()
def good():
    style = trained_style(tiny_denoiser())
    meta = {"style": "old", "content": "a person walks", "rank": 8, "iterations": 40,
            "config": {"rank": 8, "transfer_noise_step": 300, "max_seconds": None, "apply_mode": "difference"}}
    tensors = {k: v.half() for k, v in style.adapters.items()}
    tensors["example"] = torch.zeros(30, FEATURES.dim)
    return meta, tensors


def test_a_valid_file_loads(tmp_path, good):
    style = Style.load(_write(tmp_path / "ok.v2s", *good))
    assert style.meta["style"] == "old" and style.example.shape == (30, FEATURES.dim)


@pytest.mark.parametrize("change, field", [
    (lambda m, t: m["config"].update(bogus=1), "unknown field"),
    (lambda m, t: m.update(config=[1, 2]), "config: expected an object"),
    (lambda m, t: m["config"].update(transfer_noise_step=0), "config.transfer_noise_step"),
    (lambda m, t: m["config"].update(pair_noise_step=1_000_000), "config.pair_noise_step"),
    (lambda m, t: m["config"].update(apply_mode="rm -rf"), "config.apply_mode"),
    (lambda m, t: m["config"].update(style_scale=float("nan")), "config.style_scale"),
    (lambda m, t: m.update(rank=[8]), "rank: expected an integer"),
    (lambda m, t: m.update(rank=10**9), "rank: expected a number from 1 to 64"),
    (lambda m, t: m.update(style="x" * 5000), "style: expected a string"),
    (lambda m, t: m.update(tempo=100.0), "tempo"),
    (lambda m, t: t.update(example=torch.zeros(12_001, FEATURES.dim)), "example: expected"),
    pytest.param(lambda m, t: t.update(example=torch.zeros(200_000, FEATURES.dim)), "tensors too large",
                 marks=pytest.mark.slow),
    (lambda m, t: t.update(example=torch.zeros(30, 5)), "example: expected"),
    (lambda m, t: t.update({next(iter(t)): torch.full_like(t[next(iter(t))], float("nan"))}), "NaN or infinite"),
    (lambda m, t: t.update({next(iter(t)): t[next(iter(t))].to(torch.int32)}), "expected floating point"),
    (lambda m, t: t.update(weird=torch.zeros(2, 2)), "not an adapter tensor"),
])
def test_crafted_files_are_refused_in_one_line(tmp_path, good, change, field):
    meta, tensors = good
    change(meta, tensors)
    path = _write(tmp_path / "bad.v2s", meta, tensors)
    with pytest.raises(ValueError) as e:
        Style.load(path)
    msg = str(e.value)
    assert msg.startswith(str(path)) and field in msg and "\n" not in msg


def test_metadata_that_is_not_an_object_or_not_json(tmp_path, good):
    _, tensors = good
    for meta, text in [("[1, 2]", "metadata: expected an object"), ('"text"', "metadata: expected an object"),
                       ("{not json", "not a video2style style file"), ("[" * 100_000, "not a video2style style file")]:
        path = _write(tmp_path / "m.v2s", meta, tensors)
        with pytest.raises(ValueError, match=text):
            Style.load(path)


def test_adapters_that_do_not_fit_the_model_are_one_line(tmp_path, good):
    meta, tensors = good
    name = next(k for k in tensors if k.endswith("lora_b"))
    tensors[name] = torch.zeros(tensors[name].shape[0] + 3, 8, dtype=torch.float16)
    style = Style.load(_write(tmp_path / "shape.v2s", meta, tensors))
    with pytest.raises(ValueError, match=f"adapter tensor {name}: expected shape") as e:
        style_model(tiny_denoiser(), style)
    assert "\n" not in str(e.value)


def test_every_config_field_has_a_checked_range_and_the_defaults_pass():
    from dataclasses import asdict, fields

    from transfer.style_config import (
        CONFIG_RANGES,
        ApplyConfig,
        LearnConfig,
        config_dict,
        split_config,
    )
    from transfer.style_file import validate_config

    names = [f.name for f in fields(LearnConfig)] + [f.name for f in fields(ApplyConfig)]
    assert sorted(names) == sorted(CONFIG_RANGES) and len(set(names)) == len(names)  # each field in one config
    defaults = config_dict(LearnConfig(), ApplyConfig())
    assert list(defaults) == list(CONFIG_RANGES) and validate_config(dict(defaults)) == defaults
    assert split_config(defaults) == (LearnConfig(), ApplyConfig()) and split_config({}) == (LearnConfig(), ApplyConfig())
    assert {**asdict(LearnConfig()), **asdict(ApplyConfig())} == defaults
    with pytest.raises(ValueError, match="config.decode: expected one of rotations, guarded, positions"):
        validate_config({"decode": "quaternions"})


# a style file's config as learn wrote it before the config was split into LearnConfig and ApplyConfig
# (asdict of the one StyleConfig, in its field order)
CONFIG_BEFORE_THE_SPLIT = {
    "pair_step": 950, "pair_steps": 30, "guidance": 2.5, "transfer_step": 300, "transfer_steps": 6, "rank": 8,
    "lr": 0.002, "iterations": 40, "max_seconds": None, "lambda_s": 0.0, "content_batch": 8, "window": 80,
    "rec_windows": 1, "seed": 0, "pair_generation": True, "lambda_p": 0.2, "apply_mode": "difference",
    "style_scale": 0.95, "neutralize_step": 950, "guided_difference": False, "delta_smoothing": 0.0,
    "lambda_stat": 0.0, "stat_std": True, "stat_reference": "pair", "decode": "guarded", "lambda_dir": 1.0,
    "limb_guard": 0.08,
}


def test_a_style_file_from_before_the_config_split_loads_and_learn_writes_the_same_keys(tmp_path, good):
    from transfer.style_config import OLD_NAMES, ApplyConfig, config_dict

    meta, tensors = good
    meta["config"] = dict(CONFIG_BEFORE_THE_SPLIT, style_scale=1.1, lambda_p=0.5, limb_guard=0.0)
    learned, applied = Style.load(_write(tmp_path / "old.v2s", meta, tensors)).configs()
    assert (learned.lambda_p, applied.style_scale, applied.limb_guard) == (0.5, 1.1, 0.0)
    assert (learned.pair_noise_step, learned.pair_ddim_steps, learned.transfer_noise_step, learned.transfer_ddim_steps) \
        == (950, 30, 300, 6)
    # the same JSON, key for key, but for the step fields' new names (OLD_NAMES), in their places, and the fields
    # added since at the end, with their defaults
    renamed = {OLD_NAMES.get(k, k): v for k, v in meta["config"].items()}
    added = {"lambda_stat_dir": 0.0, "posture": ApplyConfig.posture, "arm_gate": ApplyConfig.arm_gate,
             "content_keep": ApplyConfig.content_keep, "content_keep_top": ApplyConfig.content_keep_top,
             "still_guard": ApplyConfig.still_guard, "arm_travel": ApplyConfig.arm_travel, "posture_between": ApplyConfig.posture_between,
             "pair_between": False, "guard_swing": ApplyConfig.guard_swing, "pair_windowed": False,
             "calibrate": False}  # (a file without a posture change applies none; one without pair_between was
    # learned before the pair was bounded: read so, whatever today's default)
    assert json.dumps(config_dict(learned, applied)) == json.dumps(renamed | added)
    partial = Style.load(_write(tmp_path / "partial.v2s", good[0] | {"config": {"decode": "rotations"}}, tensors))
    assert partial.configs()[1].decode == "rotations" and partial.configs()[0].transfer_noise_step == 300  # defaults


def test_a_style_file_with_the_old_step_names_loads_under_the_new_ones(tmp_path, good):
    meta, tensors = good
    old = dict(meta, config={"pair_step": 600, "pair_steps": 20, "transfer_step": 150, "transfer_steps": 3})
    learned, _ = Style.load(_write(tmp_path / "old.v2s", old, tensors)).configs()
    assert (learned.pair_noise_step, learned.pair_ddim_steps, learned.transfer_noise_step, learned.transfer_ddim_steps) \
        == (600, 20, 150, 3)
    with pytest.raises(ValueError, match="old.v2s: invalid style file: config.transfer_noise_step: expected a number"):
        Style.load(_write(tmp_path / "old.v2s", dict(meta, config={"transfer_step": 0}), tensors))
    both = dict(meta, config={"transfer_step": 300, "transfer_noise_step": 300})
    with pytest.raises(ValueError, match="invalid style file: config: transfer_step and transfer_noise_step are the same"):
        Style.load(_write(tmp_path / "both.v2s", both, tensors))


def test_the_posture_shift_round_trips_and_is_checked(tmp_path, good):
    from transfer.style_losses import STAT_CHANNELS

    meta, tensors = good
    assert Style.load(_write(tmp_path / "none.v2s", meta, tensors)).posture_shift is None  # files from before
    shift = torch.linspace(-1, 1, len(STAT_CHANNELS))
    style = Style.load(_write(tmp_path / "p.v2s", meta, tensors | {"posture_shift": shift}))
    assert torch.equal(style.posture_shift, shift) and "posture_shift" not in style.adapters
    style.save(tmp_path / "again.v2s")
    assert torch.equal(Style.load(tmp_path / "again.v2s").posture_shift, shift)
    for bad, message in ((shift[:5], "posture_shift: expected"), (shift * float("nan"), "NaN"),
                         (shift * 1e6, "magnitude")):
        with pytest.raises(ValueError, match=message) as e:
            Style.load(_write(tmp_path / "bad.v2s", meta, tensors | {"posture_shift": bad}))
        assert "bad.v2s" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ValueError, match="no adapter tensors"):
        Style.load(_write(tmp_path / "only.v2s", meta, {"posture_shift": shift}))
