"""No command accepts what it will later refuse; what a style file or a long input may cost is bounded; the
small things a user notices (issue 25, part B). Every test makes its own inputs."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from safetensors.torch import save_file

from motioncore.bvh import BvhError, BvhLayout, read_bvh, write_bvh
from motioncore.representation import FEATURES, encode
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion
from tests.helpers import tiny_denoiser, trained_style
from transfer.bundle import MethodBundle
from transfer.style_config import CONFIG_RANGES, check_config_value
from transfer.style_file import Style, style_model, validate_config
from video2style.cli import main


def _clip(path: Path, seconds: float = 1.0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_bvh(path, random_motion(seconds=seconds), BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    return path


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    return lines[0]


def _option_error(err: str) -> str:
    """argparse's refusal: its usage lines, then one error line (no traceback)."""
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def no_learning(monkeypatch):
    """learn_file replaced by one that records its calls: a refused option must never reach it."""
    calls = []
    monkeypatch.setattr("video2style.pipeline.learn_file", lambda *a, **k: calls.append(a) or {})
    return calls


# 1. The CLI and the style file accept the same ranges, checked before any work.

@pytest.mark.parametrize("option, value", [
    ("--iterations", "100001"), ("--iterations", "1000000000"), ("--iterations", "0"), ("--iterations", "2.5"),
    ("--max-seconds", "nan"), ("--max-seconds", "inf"), ("--max-seconds", "-1"), ("--max-seconds", "1e9"),
    ("--seed", "99999999999999999999999"), ("--seed", "abc"), ("--posture", "1.5"), ("--posture", "-0.1"),
    ("--posture", "nan"), ("--content-keep", "1.5"), ("--content-keep", "-0.1"), ("--arm-gate", "3"),
])
def test_learn_refuses_up_front_what_a_style_file_may_not_hold(tmp_path, capsys, no_learning, option, value):
    clip = _clip(tmp_path / "c.bvh")
    with pytest.raises(SystemExit) as e:
        main(["learn", str(clip), "-o", str(tmp_path / "s.v2s"), option, value])
    assert e.value.code == 2 and not no_learning and not (tmp_path / "s.v2s").exists()
    line = _option_error(capsys.readouterr().err)
    assert f"argument {option}: expected" in line and value in line
    field = option[2:].replace("-", "_")
    kind = CONFIG_RANGES[field][0]
    try:
        parsed = kind(value)
    except ValueError:
        return
    with pytest.raises(ValueError, match=f"config.{field}"):  # the style file refuses the same value
        validate_config({field: parsed})


@pytest.mark.parametrize("field", ["iterations", "max_seconds", "seed", "posture", "content_keep"])
def test_the_cli_accepts_exactly_the_schema_s_range_ends(field):
    from video2style.arguments import style_option

    kind, low, high = CONFIG_RANGES[field]
    parse = style_option(field)
    for value in (low, high):
        assert parse(str(value)) == value
        validate_config({field: value})
    import argparse

    outside = high + 1 if kind is int else high * 2
    with pytest.raises(argparse.ArgumentTypeError):
        parse(str(outside))
    with pytest.raises(ValueError):
        check_config_value(field, outside)


@pytest.mark.parametrize("option", ["--style", "--text"])
def test_learn_refuses_a_name_longer_than_a_style_file_may_hold(tmp_path, capsys, no_learning, option):
    from transfer.style_file import MAX_TEXT, validate_meta

    with pytest.raises(SystemExit):
        main(["learn", str(_clip(tmp_path / "c.bvh")), option, "x" * (MAX_TEXT + 1)])
    line = _option_error(capsys.readouterr().err)
    assert f"argument {option}: expected at most {MAX_TEXT} characters, got {MAX_TEXT + 1}" in line and not no_learning
    with pytest.raises(ValueError, match="style: expected a string of at most"):  # what apply would have said
        validate_meta({"style": "x" * (MAX_TEXT + 1)})


def test_every_seed_option_is_checked_while_parsing(tmp_path, capsys):
    for argv in (["apply", "s.v2s", "c.bvh", "-o", str(tmp_path)], ["batch", "v", "--content", "c", "-o", str(tmp_path)],
                 ["dataset"], ["train-prior"], ["train-encoder", "--prior", "p"], ["train-park"], ["evaluate"],
                 ["train-classifier", "--target", "style"]):
        with pytest.raises(SystemExit):
            main([*argv, "--seed", "99999999999999999999999"])
        assert "argument --seed: expected" in _option_error(capsys.readouterr().err)


# 2. What a style file may make apply cost is bounded.

@pytest.mark.parametrize("config, field", [
    ({"transfer_ddim_steps": 200}, "config.transfer_ddim_steps"),
    ({"window": 2000}, "config.window"),
    ({"pair_ddim_steps": 200}, "config.pair_ddim_steps"),
    ({"transfer_noise_step": 1, "apply_mode": "regenerate"}, "denoising steps per window"),  # 6 x 600 / 1 steps
    ({"pair_noise_step": 1}, "denoising steps per window"),  # neutralising: 30 x 950 / 1 steps
    ({"transfer_ddim_steps": 50, "transfer_noise_step": 200, "apply_mode": "regenerate"}, "denoising steps per window"),
])
def test_a_style_config_that_would_make_apply_slow_is_refused(config, field):
    with pytest.raises(ValueError, match=field):
        validate_config(config)


@pytest.mark.slow
def test_the_preview_s_example_panel_is_no_longer_than_the_clip(tmp_path, monkeypatch):
    from video2style.loaded_style import LoadedStyle

    monkeypatch.setattr(LoadedStyle, "stylize", lambda self, content, request: (content, {}))
    long_example = encode(random_motion(seconds=150.0))  # a style learned from a 2.5-minute input
    style = LoadedStyle(Style({}, {"style": "long"}, long_example), None, torch.nn.Module())
    info = style.apply(_clip(tmp_path / "c.bvh", seconds=1.0), tmp_path / "out")
    text = Path(info.player).read_text()
    data = json.loads(text[text.index("= {") + 2:text.rindex(";")])
    assert data["frames"] == info.frames == 20 and [p["n"] for p in data["panels"]] == [20, 20, 20]
    import cv2

    video = cv2.VideoCapture(info.preview)
    assert video.get(cv2.CAP_PROP_FRAME_COUNT) == 20
    video.release()


# 3. A long input: learning uses a bounded, most typical part of it, and says which.

def test_the_most_typical_window_of_a_long_example_is_found():
    from mlcore.windows import typical_window

    g = torch.Generator().manual_seed(0)
    x = torch.randn(2000, 8, generator=g)
    x[:300] += 5.0  # an odd start (the person walks into the frame)
    x[1800:] *= 4.0  # and a wilder end
    start = typical_window(x, 400, 20)
    assert 300 <= start and start + 400 <= 1800
    assert typical_window(x[:300], 400, 20) == 0


def test_learn_uses_a_bounded_part_of_a_long_input_and_says_which(tmp_path, monkeypatch):
    from video2style import pipeline

    seen = {}

    def learn_style(bundle, data, example, words, content, config, progress, show_bar, apply):
        seen["frames"] = example.shape[0]
        return Style({}, {"style": words, "content": content, "iterations": 40, "iterations_planned": 40}), {}

    monkeypatch.setattr("transfer.learn.learn_style", learn_style)
    monkeypatch.setattr(pipeline, "load_models", lambda device="cpu": MethodBundle(
        tiny_denoiser(), torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim)))
    monkeypatch.setattr(pipeline, "content_source", lambda progress: None)
    lines = []
    clip = _clip(tmp_path / "long.bvh", seconds=60.0)
    out = tmp_path / "long.v2s"
    pipeline.learn_file(clip, out, text="a person waves", progress=lines.append, span=(5.0, None))
    limit = int(pipeline.MAX_EXAMPLE_SECONDS * CANONICAL.fps)
    assert seen["frames"] == limit
    told = [ln for ln in lines if "learning from" in ln]
    assert len(told) == 1 and "most typical 20 s" in told[0] and "--start/--end" in told[0]
    from safetensors import safe_open

    with safe_open(str(out), framework="pt") as f:
        meta = json.loads(f.metadata()["video2style"])
        assert f.get_slice("example").get_shape()[0] == limit
    start, end = meta["example_part"]
    assert meta["span"] == [5.0, None] and f"{start:.1f}-{end:.1f} s of the input" in told[0]
    assert meta["example_seconds"] == pytest.approx(20.0) and 5.0 <= start and end - start == pytest.approx(20.0)
    assert end <= 60.0


def test_a_long_video_s_cost_is_said_before_tracking(tmp_path):
    import cv2
    import numpy as np

    from video2style.pipeline import _announce_long_video

    path = tmp_path / "long.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (32, 32))
    for i in range(300):  # 30 s at 10 fps
        writer.write(np.full((32, 32, 3), i % 255, np.uint8))
    writer.release()
    lines = []
    _announce_long_video(path, (None, None), lines.append)
    assert len(lines) == 1 and "30 s of video" in lines[0] and "--start/--end" in lines[0]
    lines.clear()
    _announce_long_video(path, (5.0, 15.0), lines.append)
    assert not lines


# 4. learn onto a full disk or an unwritable folder: one line, checked before learning where possible.

def test_a_style_file_on_a_full_disk_is_one_line_naming_it_and_leaves_nothing(tmp_path, monkeypatch, capsys):
    def full(self, data):
        raise OSError(28, "No space left on device", str(self))

    out = tmp_path / "styles" / "s.v2s"

    def learn_file(path, out_path, *a, **k):
        Style({"blocks.0.ff2.lora_a": torch.ones(8, 4)}, {"style": "s"}).save(out_path)

    monkeypatch.setattr("pathlib.Path.write_bytes", full)
    monkeypatch.setattr("video2style.pipeline.learn_file", learn_file)
    assert main(["learn", str(_clip(tmp_path / "c.bvh")), "-o", str(out)]) == 1
    line = _one_error_line(capsys.readouterr().err)
    assert line == f"video2style learn: error: {out}: No space left on device"
    assert not list(out.parent.iterdir())


def test_learn_refuses_a_nearly_full_disk_before_learning(tmp_path, monkeypatch, capsys, no_learning):
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 100_000, 100_000))
    assert main(["learn", str(_clip(tmp_path / "c.bvh")), "-o", str(tmp_path / "s.v2s")]) == 1
    assert "MB free on its disk" in _one_error_line(capsys.readouterr().err) and not no_learning
    (tmp_path / "videos").mkdir()
    (tmp_path / "videos" / "v.mp4").write_bytes(b"never read")
    assert main(["batch", str(tmp_path / "videos"), "--content", str(tmp_path), "-o", str(tmp_path / "out")]) == 1
    assert "MB free on its disk" in _one_error_line(capsys.readouterr().err) and not no_learning
    assert not (tmp_path / "out").exists()


# 5. Small things users notice.

@pytest.mark.parametrize("content", [b"", b"\x00\x00\x00\x18ftypmp42" + bytes(3000)])
def test_a_broken_video_gives_our_line_and_no_ffmpeg_log(tmp_path, content):
    path = tmp_path / "bad.mp4"
    path.write_bytes(content)
    code = "import sys\nfrom lifting.video import video_info\ntry:\n    video_info(sys.argv[1])\nexcept ValueError as e:\n    print(e, file=sys.stderr)"
    err = subprocess.run([sys.executable, "-c", code, str(path)], check=False, capture_output=True, text=True,
                         timeout=120).stderr
    assert _one_error_line(err) == f"cannot open as a video (not a video or unsupported codec): {path}"


def test_a_folder_named_like_a_video_is_called_a_folder(tmp_path):
    from lifting.video import video_info

    (tmp_path / "x.mp4").mkdir()
    with pytest.raises(ValueError, match="x.mp4: is a folder, not a video file"):
        video_info(tmp_path / "x.mp4")
    (tmp_path / "y.bvh").mkdir()
    with pytest.raises(BvhError, match="y.bvh: is a folder, not a BVH file"):
        read_bvh(tmp_path / "y.bvh")


@pytest.mark.parametrize("option, value", [("--fov", "500"), ("--fov", "nan"), ("--fov", "abc"), ("--cutoff", "-1"),
                                           ("--cutoff", "nan"), ("--cutoff", "1e9")])
def test_pose_options_are_named_and_checked_before_the_video_is_read(tmp_path, capsys, option, value):
    with pytest.raises(SystemExit) as e:  # the video does not even exist: the option is refused first
        main(["pose", str(tmp_path / "missing.mp4"), option, value])
    line = _option_error(capsys.readouterr().err)
    assert e.value.code == 2 and f"argument {option}: expected" in line and value in line


def test_a_tempo_that_is_not_a_number_names_the_option():
    from transfer.tempo import resolve_tempo

    for bad in ("abc", "nan", "9"):
        with pytest.raises(ValueError, match=f"--tempo: expected off, auto or a number from 0.5 to 1.5, got {bad}"):
            resolve_tempo(Style({}, {}), bad)


def test_apply_refuses_a_bad_tempo_before_loading_the_models(tmp_path, capsys, monkeypatch):
    def no_models(*a, **k):
        raise AssertionError("the models were loaded")

    monkeypatch.setattr("transfer.bundle.load_models", no_models)
    style = tmp_path / "s.v2s"
    Style(trained_style(tiny_denoiser()).adapters, {"style": "s", "rank": 8}).save(style)
    out = tmp_path / "out"
    assert main(["apply", str(style), str(_clip(tmp_path / "c.bvh")), "-o", str(out), "--tempo", "abc"]) == 1
    assert _one_error_line(capsys.readouterr().err).endswith("--tempo: expected off, auto or a number from 0.5 to 1.5, got abc")
    assert not out.exists()


@pytest.fixture
def good_style():
    style = trained_style(tiny_denoiser())
    meta = {"style": "old", "content": "a person walks", "rank": 8, "config": {"rank": 8}}
    return meta, {k: v.half() for k, v in style.adapters.items()}


def _save(path, meta, tensors):
    save_file({k: v.contiguous() for k, v in tensors.items()}, str(path), metadata={"video2style": json.dumps(meta)})
    return path


def test_float64_tensors_are_converted_and_huge_values_refused(tmp_path, good_style):
    meta, tensors = good_style
    wide = {k: v.double() for k, v in tensors.items()}
    wide["example"] = torch.zeros(30, FEATURES.dim, dtype=torch.float64)
    style = Style.load(_save(tmp_path / "f64.v2s", meta, wide))
    assert all(v.dtype == torch.float32 for v in style.adapters.values()) and style.example.dtype == torch.float32
    for name in ("example", next(iter(tensors))):
        bad = dict(tensors, example=torch.zeros(30, FEATURES.dim))
        bad[name] = bad[name].float().clone()
        bad[name].view(-1)[0] = 1e30
        path = _save(tmp_path / "huge.v2s", meta, bad)
        with pytest.raises(ValueError) as e:
            Style.load(path)
        assert str(e.value).startswith(str(path)) and "magnitude at most" in str(e.value) and "\n" not in str(e.value)


def test_a_tensor_shape_error_names_the_style_file(tmp_path, good_style):
    meta, tensors = good_style
    name = next(k for k in tensors if k.endswith("lora_b"))
    tensors[name] = torch.zeros(tensors[name].shape[0] + 3, 8, dtype=torch.float16)
    path = _save(tmp_path / "shape.v2s", meta, tensors)
    with pytest.raises(ValueError) as e:
        style_model(tiny_denoiser(), Style.load(path))
    assert str(e.value).startswith(f"{path}: invalid style file: adapter tensor {name}: expected shape")


def test_bvh_values_of_absurd_magnitude_are_refused_in_one_line(tmp_path):
    clip = _clip(tmp_path / "c.bvh")
    text = clip.read_text()
    lines = text.splitlines()
    at = next(i for i, ln in enumerate(lines) if "OFFSET" in ln and i > 3)
    lines[at] = "  OFFSET 1e30 0 0"
    (tmp_path / "offset.bvh").write_text("\n".join(lines) + "\n")
    with pytest.raises(BvhError, match=f"offset.bvh:{at + 1}: expected a number of magnitude at most 1e\\+07"):
        read_bvh(tmp_path / "offset.bvh")
    head, motion = text.split("MOTION\n")
    rows = motion.splitlines()
    rows[3] = "1e29 " + rows[3].split(" ", 1)[1]
    (tmp_path / "frames.bvh").write_text(head + "MOTION\n" + "\n".join(rows) + "\n")
    with pytest.raises(BvhError, match="frames.bvh: frame data holds values of magnitude above 1e\\+07") as e:
        read_bvh(tmp_path / "frames.bvh")
    assert "\n" not in str(e.value)


def test_a_latin1_joint_name_is_kept_byte_for_byte(tmp_path):
    raw = _clip(tmp_path / "c.bvh").read_bytes().replace(b"Head", b"T\xeate")  # "Tête" in Latin-1
    (tmp_path / "latin1.bvh").write_bytes(raw)
    motion, layout = read_bvh(tmp_path / "latin1.bvh")
    assert "Tête" in motion.skeleton.names and layout.encoding == "latin-1"
    write_bvh(tmp_path / "again.bvh", motion, layout)
    again = (tmp_path / "again.bvh").read_bytes()
    assert b"T\xeate" in again and "\ufffd".encode() not in again
    assert read_bvh(tmp_path / "again.bvh")[0].skeleton.names == motion.skeleton.names


def test_a_clip_whose_preview_fails_leaves_none_of_its_outputs(tmp_path, monkeypatch):
    def full_disk(*a, **k):
        raise OSError(28, "No space left on device")

    from video2style.loaded_style import LoadedStyle

    monkeypatch.setattr(LoadedStyle, "stylize", lambda self, content, request: (content, {}))
    monkeypatch.setattr("motioncore.render.render_video", full_disk)
    out = tmp_path / "out"
    with pytest.raises(OSError):
        LoadedStyle(Style({}, {}), None, torch.nn.Module()).apply(_clip(tmp_path / "c.bvh"), out)
    assert not list(out.iterdir())


def test_a_failed_batch_row_points_at_no_output(tmp_path, monkeypatch):
    from video2style.batch import apply_item

    def fails(*a, **k):
        raise OSError(28, "No space left on device")

    from video2style.loaded_style import LoadedStyle
    from video2style.options import ApplyOptions

    monkeypatch.setattr(LoadedStyle, "apply", fails)
    row = apply_item(LoadedStyle(Style({}, {}), None, None), "v.mp4", _clip(tmp_path / "c.bvh"), tmp_path / "out",
                     ApplyOptions(strength=0.5, seed=0))
    assert row["status"] == "failed" and row["output"] == row["preview"] == row["player"] == ""


def test_index_links_are_url_encoded(tmp_path):
    from video2style.batch import BatchReport, write_index

    out = tmp_path / "out"
    name = "a#b?c%20"
    for suffix in (".bvh", "_preview.mp4", "_player.js"):
        (out / "v" / f"{name}{suffix}").parent.mkdir(parents=True, exist_ok=True)
        (out / "v" / f"{name}{suffix}").write_text("x")
    report = BatchReport()
    report.add(video="v.mp4", clip=f"{name}.bvh", status="done", content=str(tmp_path / f"{name}.bvh"),
               output=str(out / "v" / f"{name}.bvh"), preview=str(out / "v" / f"{name}_preview.mp4"),
               player=str(out / "v" / f"{name}_player.js"))
    page = write_index(report, out).read_text()
    encoded = "a%23b%3Fc%2520"
    assert f'src="v/{encoded}_player.js"' in page and f'href="v/{encoded}.bvh"' in page
    import re

    assert f'href="v/{encoded}_preview.mp4"' in page and not re.search(r'(href|src)="[^"]*a#b', page)


def test_a_mix_seed_outside_the_seed_range_names_the_option():
    from video2style.park_apply import ParkRequest

    for mix in ("99999999999999999999999", "--5"):
        with pytest.raises(ValueError, match="--mix: expected a domain .* or an integer seed"):
            ParkRequest("elderly", mix=mix).validate(["elderly", "exhausted"])
    ParkRequest("elderly", mix="-3").validate(["elderly", "exhausted"])


@pytest.mark.parametrize("argv, option", [
    (["train-prior", "--lr", "nan"], "--lr"), (["train-prior", "--lr", "inf"], "--lr"),
    (["train-prior", "--batch-size", "0"], "--batch-size"), (["train-encoder", "--prior", "p", "--window", "-3"], "--window"),
    (["train-park", "--batch-size", "0"], "--batch-size"),
])
def test_training_sizes_and_rates_are_checked_while_parsing(capsys, argv, option):
    with pytest.raises(SystemExit) as e:  # refused before any run folder or weights file is touched
        main(argv)
    assert e.value.code == 2 and f"argument {option}: expected" in _option_error(capsys.readouterr().err)
