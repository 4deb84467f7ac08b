"""The loaded style, the apply request and the apply result (issue 52, item 2): one object made from a style file
through the models' bundle, one request the command line fills from one definition, one typed result."""
from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest
import torch

from tests.helpers import tiny_denoiser, trained_style, write_clip
from transfer.bundle import MethodBundle
from transfer.lora import LoRALinear
from video2style.loaded_style import LoadedStyle
from video2style.options import ApplyOptions, apply_options
from video2style.result import ApplyResult


def test_a_style_file_loads_as_one_object_on_the_bundle_given(tmp_path):
    bundle = MethodBundle(tiny_denoiser())
    style = trained_style(bundle.prior)
    style.meta.update({"style": "old", "source": "old.mp4", "iterations": 40})
    path = tmp_path / "old.v2s"
    style.save(path)
    loaded = LoadedStyle.from_file(path, bundle=bundle)
    assert loaded.bundle is bundle and loaded.path == path and loaded.style.meta["style"] == "old"
    assert set(loaded.style.adapters) == set(style.adapters)
    for name, tensor in style.adapters.items():  # saved as float16
        assert torch.allclose(loaded.style.adapters[name], tensor.half().float())
    assert loaded.model is not bundle.prior and not any(isinstance(m, LoRALinear) for m in bundle.prior.modules())
    assert any(isinstance(m, LoRALinear) for m in loaded.model.modules()) and not loaded.model.training
    assert loaded.describe(0.6) == "style old, learned from old.mp4, 40 iterations; applied at strength 0.6"
    assert loaded.warning() is None  # learned on no recorded prior


def test_a_bad_style_file_is_refused_in_one_line_before_any_model_is_made(tmp_path, monkeypatch):
    bad = tmp_path / "bad.v2s"
    bad.write_bytes(b"not a safetensors file")
    monkeypatch.setattr("transfer.bundle.load_models", lambda device="cpu": pytest.fail("models loaded"))
    with pytest.raises(ValueError, match="not a video2style style file") as e:
        LoadedStyle.from_file(bad)
    assert "\n" not in str(e.value) and str(e.value).startswith(str(bad))


@pytest.mark.parametrize("command", ["apply", "batch"])
def test_apply_and_batch_fill_the_one_request_from_the_one_definition(command):
    from video2style.cli import build_parser

    head = ["apply", "s.v2s", "c.bvh", "-o", "out"] if command == "apply" else ["batch", "s.v2s", "--content", "lib",
                                                                                "-o", "out"]
    parser = build_parser()
    assert apply_options(parser.parse_args(head)) == ApplyOptions()  # every default is the request's own
    args = parser.parse_args(head + ["--strength", "0.7", "--seed", "3", "--neutralize", "never", "--no-preview",
                                     "--tempo", "0.8", "--joint-map", "map.json", "--format", "fbx",
                                     "--armature", "Rig", "--action", "Take 1"])
    assert apply_options(args) == ApplyOptions(strength=0.7, tempo="0.8", seed=3, neutralize="never", preview=False,
                                               joint_map=Path("map.json"), format="fbx", armature="Rig",
                                               action="Take 1")
    with pytest.raises(ValueError, match="--strength"):
        apply_options(parser.parse_args(head + ["--strength", "1.5"]))


def test_every_request_field_has_its_option_in_the_field_order():
    from video2style.cli import build_parser

    text = build_parser()._subparsers._group_actions[0].choices["apply"].format_help()
    flags = [f.metadata["flags"][0] for f in fields(ApplyOptions) if f.metadata["flags"]]
    assert flags == ["--strength", "--tempo", "--feet", "--seed", "--neutralize", "--no-preview", "--joint-map"]
    at = [text.index(f"  {flag}") for flag in flags + ["--armature", "--action", "--format"]]
    assert at == sorted(at)


def test_the_result_reports_what_was_measured_in_its_field_order():
    result = ApplyResult("walk.bvh", ["out/walk.bvh"], frames=80, tempo=1.0, detected=None, neutralized=False,
                         skating_content=0.0, skating_before=0.1, skating_after=0.05, rolls_conformed=False,
                         change={"joints_cm": 1.0, "parts_cm": {}, "most": None, "shows": "lightly"}, seconds=1.5,
                         seconds_transfer=1.0, streamed=2)
    row = result.reported()
    assert list(row) == ["input", "output", "frames", "tempo", "detected", "neutralized", "skating_content",
                         "skating_before", "skating_after", "rolls_conformed", "change", "seconds", "seconds_transfer"]
    assert row["output"] == "out/walk.bvh" == result.output and row["detected"] is None  # read: not at all
    reported = [f.name for f in fields(ApplyResult) if f.metadata.get("reported")]
    assert "streamed" not in reported and reported[:2] == ["input", "outputs"]
    park = ApplyResult("walk.bvh", ["a_x.bvh", "a_y.bvh"], frames=80, skating_before=0.1)
    assert park.reported() == {"input": "walk.bvh", "output": ["a_x.bvh", "a_y.bvh"], "frames": 80,
                               "skating_before": 0.1}  # no reading: no detected
    result.add_files({"outputs": ["o.bvh"], "preview": "p.mp4"})
    assert (result.outputs, result.preview, result.player) == (["o.bvh"], "p.mp4", None)


def test_apply_fills_the_result_and_writes_the_clip(tmp_path, monkeypatch):
    from motioncore.bvh import read_bvh
    from transfer.style_file import Style
    from video2style.summary import clip_details

    calls = []

    def stylize(self, motion, request):
        calls.append(request)
        return motion, {"detected": "walk", "neutralized": False, "skating_before": 0.2, "skating_after": 0.1,
                        "skating_content": 0.0, "still_share": 0.5}

    monkeypatch.setattr(LoadedStyle, "stylize", stylize)
    clip = write_clip(tmp_path / "c.bvh", seconds=1.0)
    request = ApplyOptions(strength=0.3, seed=2, preview=False)
    result = LoadedStyle(Style({}, {"style": "s"}), None, torch.nn.Module()).apply(clip, tmp_path / "out", request)
    assert calls == [request] and isinstance(result, ApplyResult)
    assert result.outputs == [str(tmp_path / "out" / "c.bvh")] and result.preview is None is result.player
    assert result.frames == 20 and result.tempo == 1.0 and result.still_share == 0.5 and result.detected == "walk"
    assert result.change["shows"] == "barely" and result.seconds >= result.seconds_transfer > 0
    assert read_bvh(result.output)[0].num_frames == read_bvh(clip)[0].num_frames
    row = clip_details(result)
    assert list(row)[:3] == ["input", "output", "frames"] and row["notes"][-1].startswith("the style model barely")
    assert row["guards_held"] == ["still-pose guard left out 50% of the fast change"]


def test_apply_reads_the_request_s_joint_map_when_it_is_not_given_read(tmp_path, monkeypatch):
    from transfer.style_file import Style

    read = []
    monkeypatch.setattr("motioncore.retarget.load_joint_map", lambda path: read.append(path) or None)
    monkeypatch.setattr(LoadedStyle, "stylize", lambda self, motion, request: (motion, {}))
    style = LoadedStyle(Style({}, {}), None, torch.nn.Module())
    clip = write_clip(tmp_path / "c.bvh")
    style.apply(clip, tmp_path / "a", ApplyOptions(preview=False, joint_map=tmp_path / "map.json"))
    style.apply(clip, tmp_path / "b", ApplyOptions(preview=False, joint_map=tmp_path / "map.json"), joint_map={})
    style.apply(clip, tmp_path / "c", ApplyOptions(preview=False))
    assert read == [tmp_path / "map.json"]  # read once: the caller's map is used as it is
