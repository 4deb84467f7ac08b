"""Style files are untrusted: crafted metadata and tensors give one line naming the file and the field."""
from __future__ import annotations

import json

import pytest
import torch
from safetensors.torch import save_file

from motioncore.representation import FEATURES
from tests.test_style import _trained_style, tiny_denoiser
from transfer.style import Style, style_model


def _write(path, meta, tensors):
    save_file({k: v.contiguous() for k, v in tensors.items()}, str(path),
              metadata={"video2style": meta if isinstance(meta, str) else json.dumps(meta)})
    return path


@pytest.fixture()
def good():
    style = _trained_style(tiny_denoiser())
    meta = {"style": "old", "content": "a person walks", "rank": 8, "iterations": 40,
            "config": {"rank": 8, "transfer_step": 300, "max_seconds": None, "apply_mode": "difference"}}
    tensors = {k: v.half() for k, v in style.adapters.items()}
    tensors["example"] = torch.zeros(30, FEATURES.dim)
    return meta, tensors


def test_a_valid_file_loads(tmp_path, good):
    style = Style.load(_write(tmp_path / "ok.v2s", *good))
    assert style.meta["style"] == "old" and style.example.shape == (30, FEATURES.dim)


@pytest.mark.parametrize("change, field", [
    (lambda m, t: m["config"].update(bogus=1), "unknown field"),
    (lambda m, t: m.update(config=[1, 2]), "config: expected an object"),
    (lambda m, t: m["config"].update(transfer_step=0), "config.transfer_step"),
    (lambda m, t: m["config"].update(pair_step=1_000_000), "config.pair_step"),
    (lambda m, t: m["config"].update(apply_mode="rm -rf"), "config.apply_mode"),
    (lambda m, t: m["config"].update(style_scale=float("nan")), "config.style_scale"),
    (lambda m, t: m.update(rank=[8]), "rank: expected an integer"),
    (lambda m, t: m.update(rank=10**9), "rank: expected a number from 1 to 64"),
    (lambda m, t: m.update(style="x" * 5000), "style: expected a string"),
    (lambda m, t: m.update(tempo=100.0), "tempo"),
    (lambda m, t: t.update(example=torch.zeros(12_001, FEATURES.dim)), "example: expected"),
    (lambda m, t: t.update(example=torch.zeros(200_000, FEATURES.dim)), "tensors too large"),
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

    from transfer.style_config import StyleConfig
    from transfer.style_schema import CONFIG_RANGES, validate_config

    assert {f.name for f in fields(StyleConfig)} == set(CONFIG_RANGES)
    assert validate_config(asdict(StyleConfig())) == asdict(StyleConfig())
    with pytest.raises(ValueError, match="config.decode: expected one of rotations, guarded, positions"):
        validate_config({"decode": "quaternions"})
