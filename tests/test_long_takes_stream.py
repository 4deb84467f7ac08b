"""Long BVH takes applied a span at a time (issue 25): span reads equal the whole read, the span writer writes
what write_bvh writes (or nothing), and a streamed apply equals the whole-clip apply."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch

import transfer.apply as apply_mod
from mlcore.shipped import SHIPPED as WEIGHTS
from motioncore.bvh import BvhError, read_bvh, write_bvh
from motioncore.bvh_stream import BvhFrames, BvhSpanWriter
from motioncore.motion import Motion, resample, resample_span
from testkit.motions import cmu_like_skeleton
from video2style import long_takes


def _walk(frames: int, fps: float) -> Motion:
    """A walk-like take on a CMU-like skeleton: swinging legs and arms, a turning path."""
    sk = cmu_like_skeleton()
    t = torch.arange(frames, dtype=torch.float32) / fps
    from motioncore import quat

    angles = torch.zeros(frames, sk.num_joints, 3)
    for j in range(1, sk.num_joints):
        angles[:, j, 0] = 0.3 * torch.sin(2 * math.pi * 0.9 * t + j)
    lrot = quat.from_euler(angles, "ZXY")
    lrot[:, 0] = quat.mul(quat.from_yaw(0.1 * t), lrot[:, 0])
    lpos = sk.offsets.expand(frames, -1, -1).clone()
    lpos[:, 0, 0] = torch.cumsum(torch.sin(0.1 * t), 0) * 1.2 / fps
    lpos[:, 0, 1] = 0.95 + 0.02 * torch.sin(4 * math.pi * 0.9 * t)
    lpos[:, 0, 2] = torch.cumsum(torch.cos(0.1 * t), 0) * 1.2 / fps
    return Motion(sk, lrot, lpos, fps)


def test_span_reads_equal_the_whole_read(tmp_path):
    path = tmp_path / "take.bvh"
    write_bvh(path, _walk(97, 30.0))
    text = path.read_text()
    # blank lines between frames and CRLF line ends are read as the whole reader reads them
    head, body = text.split("Frame Time:")
    lines = body.split("\n")
    odd = tmp_path / "odd.bvh"
    odd.write_bytes((head + "Frame Time:" + "\n\n".join(lines[:40]) + "\n  \n" + "\n".join(lines[40:])).replace(
        "\n", "\r\n").encode())
    for p in (path, odd):
        whole, layout = read_bvh(p)
        frames = BvhFrames(p)
        assert (frames.num_frames, frames.fps, frames.layout) == (97, whole.fps, layout)
        assert BvhFrames.declared(p) == (97, pytest.approx(1 / 30, abs=1e-7))
        for a, b in ((0, 97), (0, 1), (5, 41), (40, 41), (60, 97)):
            part = frames[a:b]
            assert part.skeleton.names == whole.skeleton.names
            assert torch.equal(part.lrot, whole.lrot[a:b]) and torch.equal(part.lpos, whole.lpos[a:b])


def test_span_reader_refuses_a_wrong_frame_count_and_bad_numbers(tmp_path):
    path = tmp_path / "take.bvh"
    write_bvh(path, _walk(20, 30.0))
    text = path.read_text()
    short = tmp_path / "short.bvh"
    short.write_text(text.replace("Frames: 20", "Frames: 21"))
    with pytest.raises(BvhError, match="short.bvh: declared 21 frames, found 20"):
        BvhFrames(short)
    rows = text.splitlines()
    rows[-3] = rows[-3].replace(rows[-3].split()[4], "abc", 1)
    rows.insert(-5, "   ")  # a blank line among the frames: the line numbers count it
    bad = tmp_path / "bad.bvh"
    bad.write_text("\n".join(rows) + "\n")
    frames = BvhFrames(bad)
    assert torch.isfinite(frames[0:10].lrot).all()
    with pytest.raises(BvhError, match=f"bad.bvh:{len(rows) - 2}: expected numbers in the frame data$"):
        frames[10:20]  # the file's line, not the span's frames
    rows[-3] = " ".join(rows[-4].split()[:-1])  # a frame a number short
    bad.write_text("\n".join(rows) + "\n")
    with pytest.raises(BvhError, match=f"bad.bvh:{len(rows) - 2}: expected .* values per frame, got "):
        BvhFrames(bad)[15:20]


def test_span_resampling_equals_the_whole(tmp_path):
    m = _walk(50, 30.0)
    whole = resample(m, 20.0)
    for a, b in ((0, 7), (7, 20), (20, whole.num_frames)):
        s0 = max(0, math.floor(a * 1.5) - 1)
        s1 = min(50, math.floor((b - 1) * 1.5) + 3)
        part = resample_span(m.slice(s0, s1), 20.0, a, b, first=s0, total=50)
        assert torch.equal(part.lrot, whole.lrot[a:b]) and torch.equal(part.lpos, whole.lpos[a:b])
    with pytest.raises(ValueError, match="expected frames"):
        resample_span(m.slice(10, 20), 20.0, 0, 5, first=10, total=50)


def test_span_writer_writes_what_write_bvh_writes_or_nothing(tmp_path):
    m = _walk(23, 30.0)
    write_bvh(tmp_path / "whole.bvh", m)
    _, layout = read_bvh(tmp_path / "whole.bvh")
    with BvhSpanWriter(tmp_path / "spans.bvh", m.skeleton, layout, 23, m.fps) as w:
        for a in range(0, 23, 5):
            w.append(m.slice(a, min(a + 5, 23)))
    assert (tmp_path / "spans.bvh").read_text() == (tmp_path / "whole.bvh").read_text()
    with (pytest.raises(ValueError, match="expected 23 frames, wrote 10; nothing written"),
          BvhSpanWriter(tmp_path / "few.bvh", m.skeleton, layout, 23, m.fps) as w):
        w.append(m.slice(0, 10))
    with (pytest.raises(RuntimeError, match="disk"),
          BvhSpanWriter(tmp_path / "failed.bvh", m.skeleton, layout, 23, m.fps) as w):
        w.append(m.slice(0, 10))
        raise RuntimeError("disk full")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spans.bvh", "whole.bvh"]


shipped = pytest.mark.skipif(not (WEIGHTS / "denoiser.safetensors").is_file(), reason="shipped weights not present")


@pytest.fixture(scope="module")
def loaded_style(tmp_path_factory):
    from transfer.style_config import LearnConfig
    from video2style.demo import SAMPLES
    from video2style.loaded_style import LoadedStyle
    from video2style.pipeline import learn_file

    torch.set_num_threads(1)
    out = tmp_path_factory.mktemp("style") / "s.v2s"
    mp = pytest.MonkeyPatch()
    mp.setenv("VIDEO2STYLE_DATA", str(out.parent / "no-cache"))  # the bundled content bank
    try:
        learn_file(SAMPLES / "walk_prior.bvh", out, "s", None, LearnConfig(iterations=2, pair_ddim_steps=3),
                   progress=lambda s: None, allow_partial=True)
    finally:
        mp.undo()
    return LoadedStyle.from_file(out)


@pytest.mark.slow
@shipped
@pytest.mark.parametrize("neutralize", ["never", "always"])
def test_streamed_apply_equals_the_whole_clip_apply(tmp_path, monkeypatch, loaded_style, neutralize):
    from video2style.options import ApplyOptions

    style = loaded_style
    # the stray-limb guard and the posture match read each span's time means (45 frames here), not the whole take's
    monkeypatch.setitem(style.style.meta["config"], "limb_guard", 0.0)
    monkeypatch.setitem(style.style.meta["config"], "posture", 0.0)
    clip = tmp_path / "take.bvh"
    write_bvh(clip, _walk(450, 30.0))  # 300 canonical frames: 5 windows
    monkeypatch.setattr(apply_mod, "WINDOW_BATCH", 2)  # 3 batches, finished across the spans' ends
    # --feet lock: auto keeps or leaves each span's cleanup as its own sliding says (measured per span, as the guards
    # reading time means read each span), so only the locked feet are the same whole and streamed
    whole = style.apply(clip, tmp_path / "whole", ApplyOptions(preview=False, neutralize=neutralize, feet="lock"))
    assert whole.streamed is None
    monkeypatch.setattr(long_takes, "LONG_TAKE_SECONDS", 10.0)  # 15 s: a long take now
    monkeypatch.setattr(long_takes, "SPAN_FRAMES", 45)
    monkeypatch.setattr(long_takes, "MARGIN", 20)
    streamed = style.apply(clip, tmp_path / "streamed", ApplyOptions(preview=True, neutralize=neutralize, feet="lock"))
    assert streamed.streamed == 7 and "span" in streamed.stream_note
    assert streamed.neutralized == whole.neutralized == (neutralize == "always")
    a, la = read_bvh(whole.output)
    b, lb = read_bvh(streamed.output)
    assert (b.num_frames, b.fps, lb) == (a.num_frames, a.fps, la)
    text_a, text_b = Path(whole.output).read_text(), Path(streamed.output).read_text()
    assert text_a.split("MOTION")[0] == text_b.split("MOTION")[0]
    assert text_a.splitlines()[len(text_a.split("MOTION")[0].splitlines()):][:3] == \
        text_b.splitlines()[len(text_b.split("MOTION")[0].splitlines()):][:3]  # MOTION, Frames:, Frame Time:
    gap = (a.global_positions() - b.global_positions()).norm(dim=-1).max()
    assert gap < 0.0005, f"{100 * gap:.4f} cm"
    assert Path(streamed.preview).is_file() and Path(streamed.player).is_file()


@pytest.mark.slow
@shipped
def test_every_guard_runs_on_a_streamed_take(tmp_path, monkeypatch, loaded_style):
    """One apply path (transfer.spans): a take streamed in one span, every guard on, is the whole-clip result."""
    from video2style.options import ApplyOptions

    style = loaded_style
    clip = tmp_path / "take.bvh"
    write_bvh(clip, _walk(450, 30.0))
    whole = style.apply(clip, tmp_path / "whole", ApplyOptions(preview=False, neutralize="never"))
    monkeypatch.setattr(long_takes, "LONG_TAKE_SECONDS", 10.0)
    monkeypatch.setattr(long_takes, "SPAN_FRAMES", 1_000)  # one span: the guards see what the whole clip's see
    streamed = style.apply(clip, tmp_path / "streamed", ApplyOptions(preview=False, neutralize="never"))
    assert streamed.streamed == 1 and "each span on its own" in streamed.stream_note
    for key in ("still_share", "arm_motion_share", "content_share", "rolls_conformed"):
        assert getattr(streamed, key) == pytest.approx(getattr(whole, key), abs=1e-3), key
    a, b = read_bvh(whole.output)[0], read_bvh(streamed.output)[0]
    gap = (a.global_positions() - b.global_positions()).norm(dim=-1).max()
    assert gap < 0.0005, f"{100 * gap:.4f} cm"


@pytest.mark.slow
@shipped
def test_a_failure_midway_leaves_no_output(tmp_path, monkeypatch, loaded_style):
    from video2style.options import ApplyOptions

    style = loaded_style
    clip = tmp_path / "take.bvh"
    write_bvh(clip, _walk(450, 30.0))
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise OSError("No space left on device")
        return real(*args, **kwargs)

    real = long_takes.carry_edit
    monkeypatch.setattr(long_takes, "carry_edit", failing)
    monkeypatch.setattr(long_takes, "LONG_TAKE_SECONDS", 10.0)
    monkeypatch.setattr(long_takes, "SPAN_FRAMES", 45)
    monkeypatch.setattr(long_takes, "MARGIN", 20)
    out = tmp_path / "out"
    with pytest.raises(OSError, match="No space"):
        style.apply(clip, out, ApplyOptions(neutralize="never"))
    assert len(calls) == 3 and (not out.exists() or list(out.iterdir()) == [])


@pytest.mark.slow
@shipped
def test_a_tempo_keeps_the_whole_clip_path_and_says_so(tmp_path, monkeypatch, loaded_style):
    from video2style.options import ApplyOptions

    style = loaded_style
    clip = tmp_path / "take.bvh"
    write_bvh(clip, _walk(300, 30.0))
    monkeypatch.setattr(long_takes, "LONG_TAKE_SECONDS", 5.0)
    info = style.apply(clip, tmp_path / "out", ApplyOptions(preview=False, neutralize="never", tempo="0.9"))
    assert info.streamed is None and info.tempo == 0.9
    assert "applied whole (--tempo 0.9)" in info.stream_note
