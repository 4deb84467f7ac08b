"""Issue 51: batch takes every apply option (one definition), reuses style files, and says what happened."""
import argparse
import json
from pathlib import Path

import pytest

from tests.helpers import make_library
from video2style.cli import build_parser, main

PARK_ONLY = {"--method", "--domain", "--variants", "--reference", "--mix", "--mix-steps", "--park-weights", "--weights"}


def _commands():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["apply"], sub.choices["batch"]


def _options(parser) -> dict:
    return {a.option_strings[-1]: a for a in parser._actions if a.option_strings}


def test_batch_has_every_apply_option_with_the_same_meaning():
    apply, batch = _commands()
    a, b = _options(apply), _options(batch)
    shared = set(a) - PARK_ONLY
    assert {"--strength", "--tempo", "--seed", "--neutralize", "--format", "--no-preview", "--joint-map"} <= shared
    missing = sorted(shared - set(b))
    assert not missing, f"batch lacks {missing}"
    for name in shared - {"--output", "--help"}:  # -o: a folder in both, laid out per command
        x, y = a[name], b[name]
        assert (x.dest, x.default, x.choices, x.help, x.type, x.nargs, x.const) == \
            (y.dest, y.default, y.choices, y.help, y.type, y.nargs, y.const), name


def test_batch_passes_every_apply_option_to_apply(tmp_path, fake_pipeline):
    videos, content = make_library(tmp_path)
    out = tmp_path / "out"
    assert main(["batch", str(videos / "strut.mp4"), "--content", str(content), "-o", str(out), "--strength", "0.7",
                 "--seed", "3", "--tempo", "0.8", "--neutralize", "never", "--no-preview", "--feet", "lock"]) == 0
    assert fake_pipeline["apply_args"] and set(fake_pipeline["apply_args"]) == {(0.7, 3, "never", None, False, "0.8",
                                                                                 "lock")}


def test_batch_refuses_a_bad_apply_option_in_one_line_before_any_work(tmp_path, fake_pipeline, capsys):
    videos, content = make_library(tmp_path)
    assert main(["batch", str(videos), "--content", str(content), "-o", str(tmp_path / "out"), "--tempo", "9"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--tempo" in err and not fake_pipeline["learn"]


def test_batch_reuses_style_files_and_takes_mixed_sources(tmp_path, fake_pipeline):
    videos, content = make_library(tmp_path)
    mine = tmp_path / "styles_made" / "mine.v2s"
    mine.parent.mkdir()
    mine.write_text("style")  # what the fake loader takes for a style file
    example = tmp_path / "proud.bvh"
    example.write_text("clip")
    out = tmp_path / "out"
    assert main(["batch", str(mine), str(videos / "strut.mp4"), str(example), "--content", str(content),
                 "-o", str(out)]) == 0
    assert sorted(fake_pipeline["learn"]) == ["proud.bvh", "strut.mp4"]  # the style file is not learned again
    assert (out / "mine" / "run.bvh").is_file() and not (out / "styles" / "mine.v2s").exists()
    assert (out / "proud" / "a" / "walk.bvh").is_file() and (out / "styles" / "proud.v2s").is_file()
    rows = json.loads((out / "report.json").read_text())
    assert {r["video"] for r in rows} == {"mine.v2s", "strut.mp4", "proud.bvh"}
    # a folder gives its videos and its style files
    (videos / "kept.v2s").write_text("style")
    fake_pipeline["learn"].clear()
    assert main(["batch", str(videos), "--content", str(content), "-o", str(tmp_path / "out2")]) == 0
    assert sorted(fake_pipeline["learn"]) == ["old.mov", "old.mp4", "strut.mp4"]
    assert (tmp_path / "out2" / "kept" / "run.bvh").is_file()


def test_a_style_file_that_does_not_load_is_one_failed_item(tmp_path, fake_pipeline):
    _, content = make_library(tmp_path)
    bad = tmp_path / "bad.v2s"
    bad.write_bytes(b"\x00garbage")
    assert main(["batch", str(bad), "--content", str(content), "-o", str(tmp_path / "out")]) == 1
    rows = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rows[0]["status"] == "failed" and rows[0]["error"].startswith("style:") and not fake_pipeline["learn"]
    assert Path(bad).read_bytes() == b"\x00garbage"  # never learned over


SAMPLES = Path(__file__).resolve().parents[1] / "samples"


@pytest.fixture(scope="module")
def quick_style(tmp_path_factory):
    """A style learned in two iterations from a sample clip (partial: enough to apply)."""
    import os

    from transfer.style_config import LearnConfig
    from video2style.pipeline import learn_file

    where = tmp_path_factory.mktemp("style")
    old = os.environ.get("VIDEO2STYLE_DATA")
    os.environ["VIDEO2STYLE_DATA"] = str(where / "no-cache")  # the bundled content bank
    try:
        learn_file(SAMPLES / "walk_prior.bvh", where / "old.v2s", "old", None,
                   LearnConfig(iterations=2, pair_ddim_steps=3), progress=lambda s: None, allow_partial=True)
    finally:
        if old is None:
            os.environ.pop("VIDEO2STYLE_DATA")
        else:
            os.environ["VIDEO2STYLE_DATA"] = old
    return where / "old.v2s"


def _lines(text: str, start: str) -> list[str]:
    return [ln.strip() for ln in text.splitlines() if ln.strip().startswith(start)]


@pytest.mark.slow
def test_apply_says_in_one_short_plain_line_per_clip_what_happened_and_writes_the_page(quick_style, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["apply", str(quick_style), str(SAMPLES / "run_prior.bvh"), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    [line] = _lines(printed, "[1/1]")
    said = line.split(".bvh: ", 1)[1]  # after the paths
    assert len(said) < 200 and "P(content)" not in line and "similarity" not in line, line
    # the file's own frames and seconds (the sample: 85 frames at 30 fps), not the canonical frames nor a run time
    assert "85 frames at 30 fps, 2.83 s" in line and "style shows" in line and "feet slide in" in line
    row = json.loads((out / "report.json").read_text())[0]
    assert row["file_frames"] == 85 and row["change"]["joints_cm"] > 0 and row["summary"] in line
    assert {"skating_content", "skating_after", "detected"} <= set(row)
    index = (out / "index.html").read_text()  # the page batch and demo write, with the clip's player
    assert "run_prior_player.js" in index and 'class="player"' in index and "index.html" in printed


@pytest.mark.slow
def test_batch_prints_a_line_per_clip_and_its_report_holds_the_numbers(quick_style, tmp_path, capsys):
    content = tmp_path / "content"
    content.mkdir()
    (content / "run.bvh").write_text((SAMPLES / "run_prior.bvh").read_text())
    out = tmp_path / "out"
    assert main(["batch", str(quick_style), "--content", str(content), "-o", str(out), "--no-preview"]) == 0
    [line] = _lines(capsys.readouterr().out, "[1/1]")
    assert "style shows" in line and "feet slide in" in line and "P(content)" not in line
    [row] = json.loads((out / "report.json").read_text())
    assert row["status"] == "done" and row["change"]["joints_cm"] > 0 and row["file_frames"] == 85
    assert 0 <= row["skating_after"] <= 1 and row["summary"] in line and not (out / "styles").exists()


def test_the_line_names_the_guards_that_held_the_style_back():
    from video2style.result import ApplyResult
    from video2style.summary import clip_line

    line = clip_line(ApplyResult("c.bvh", frames=80, file_frames=119, file_fps=30.0, skating_content=0.0,
                                 skating_after=0.2, still_share=0.91, arm_motion_share=0.03, content_share=0.999,
                                 neutralized=True, change={"joints_cm": 2.4, "most": "legs", "shows": "lightly"}))
    assert line == ("119 frames at 30 fps, 3.97 s; style shows lightly (joints moved 2.4 cm on average, most in the "
                    "legs); neutralised first; feet slide in 0% of frames before, 20% after; held back: still-pose "
                    "guard left out 9% of the fast change; arms kept their own motion (3% of the style's)")


@pytest.mark.slow
def test_learn_says_each_number_in_the_files_own_frames_and_seconds_and_a_guess_as_a_guess(tmp_path, monkeypatch,
                                                                                          capsys):
    from transfer.apply import Reading

    monkeypatch.setenv("VIDEO2STYLE_DATA", str(tmp_path / "no-cache"))
    unsure = Reading("walk-turn-left", "normal", 0.2, 0.1, 0.5,
                     (("a person walks and turns left", 0.5), ("a person walks", 0.48), ("a person runs", 0.4)))
    monkeypatch.setattr("transfer.apply.read_motion", lambda *a, **k: unsure)
    out = tmp_path / "s.v2s"
    assert main(["learn", str(SAMPLES / "walk_prior.bvh"), "--style", "taiji", "-o", str(out), "--iterations", "2",
                 "--allow-partial"]) == 0
    printed = capsys.readouterr().out
    # the sample: 119 frames at 30 fps (3.97 s); the models read it as 80 frames at 20 fps; no run time as a length
    assert "3.97 s: 119 frames at 30 fps in the file (80 frames at 20 fps on the canonical skeleton; read in" in printed
    [last] = _lines(printed, "learned style")
    assert "taiji' (" not in last and "not recognised with confidence" in last and "--text" in last, last
    assert "content by retrieval: 'walk-turn-left'" not in printed and "closest guess 'walk-turn-left'" in printed
    from transfer.style_file import Style

    assert Style.load(out).meta["content_confident"] is False


def test_pose_and_the_demo_say_the_bvh_length_apart_from_the_tracking_speed(tmp_path, monkeypatch, capsys):
    info = {"video": "elderly.mp4", "bvh": str(tmp_path / "pose" / "elderly.bvh"), "preview": "p.mp4", "frames": 119,
            "tracked_frames": 119, "bvh_frames": 119, "bvh_fps": 30.0, "bvh_seconds": 119 / 30, "trajectory": "contacts",
            "fps": 24.8}
    monkeypatch.setattr("video2style.pose.pose_file", lambda *a, **k: info)
    video = tmp_path / "elderly.mp4"
    video.write_bytes(b"x")
    assert main(["pose", str(video), "-o", str(tmp_path / "e.bvh")]) == 0
    line = capsys.readouterr().out
    assert "119 frames at 30 fps (3.97 s)" in line and "tracking ran at 24.8 video frames a second" in line
    from video2style import batch
    from video2style.demo import run_demo

    monkeypatch.setattr(batch, "run_batch", lambda *a, **k: batch.BatchReport())
    monkeypatch.setattr("lifting.blazepose.assets.find_models", lambda *a, **k: None)
    lines = []
    run_demo(tmp_path / "demo", progress=lines.append)
    said = "\n".join(lines)
    assert "(119 frames at 30 fps, 3.97 s; tracked at 25 video frames a second)" in said
    assert "first use: fetching the pose models" in said and "36 MB" in said and "models --wheel FILE" in said


def test_the_quickstart_says_the_first_video_fetches_36_mb_and_how_to_do_it_offline():
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    quick = readme.split("## Quickstart", 1)[1].split("\n## ", 1)[0]
    assert "36 MB" in quick and "video2style models --wheel" in quick
