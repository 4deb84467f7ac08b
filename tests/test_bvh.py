import math
import re

import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motioncore import quat
from motioncore.bvh import (
    BvhError,
    BvhLayout,
    format_bvh,
    parse_bvh,
    read_bvh,
    write_bvh,
)
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL
from testkit.motions import bandai_like_skeleton, cmu_like_skeleton, random_motion

SMALL = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 5 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 90 2 0 0 0 0 0 0
1 90 2 90 0 0 0 0 90
"""


def _same(m1, m2, tol=1e-5):
    assert (m1.global_positions() - m2.global_positions()).abs().max() < tol
    assert ((m1.lrot * m2.lrot).sum(-1).abs() > 1 - 1e-6).all()


def test_known_values_cm_and_euler_order():
    m, layout = parse_bvh(SMALL, "small.bvh", units="cm")
    assert m.fps == 30.0 and layout.scale == 0.01
    assert torch.allclose(m.lpos[0, 0], torch.tensor([0.01, 0.9, 0.02]))
    # frame 1: Hips Zrotation 90 -> the chest bone (0, 0.1, 0) points along -X
    p = m.global_positions()
    assert torch.allclose(p[1, 1] - p[1, 0], torch.tensor([-0.1, 0.0, 0.0]), atol=1e-6)
    assert layout.channels[1] == ("Xrotation", "Yrotation", "Zrotation")
    assert 1 in m.skeleton.end_sites


def test_crlf_tabs_and_units_auto():
    m1, _ = parse_bvh(SMALL, "a.bvh", units="cm")
    m2, _ = parse_bvh(SMALL.replace("\n", "\r\n").replace("\t", "    "), "b.bvh", units="cm")
    _same(m1, m2)


@pytest.mark.parametrize("make,order,scale", [(bandai_like_skeleton, "ZXY", 0.01), (cmu_like_skeleton, "ZYX", 0.0564)])
def test_read_write_read_round_trip(tmp_path, make, order, scale):
    sk = make()
    m = random_motion(seconds=2.0, seed=11)
    lrot = quat.normalize(torch.randn(m.num_frames, sk.num_joints, 4, generator=torch.Generator().manual_seed(1)))
    lpos = sk.offsets.expand(m.num_frames, -1, -1).clone()
    lpos[:, 0] = m.lpos[:, 0]
    motion = Motion(sk, lrot, lpos, 30.0)
    if make is bandai_like_skeleton:  # every joint with 6 channels, like Bandai
        rot = tuple(f"{a}rotation" for a in order)
        layout = BvhLayout(tuple(("Xposition", "Yposition", "Zposition") + rot for _ in sk.names), scale)
    else:
        layout = BvhLayout.default(sk, order, scale)
    path = tmp_path / "clip.bvh"
    write_bvh(path, motion, layout)
    m2, layout2 = read_bvh(path, units=scale)
    assert layout2.channels == layout.channels
    _same(motion, m2)
    write_bvh(tmp_path / "again.bvh", m2, layout2)
    m3, _ = read_bvh(tmp_path / "again.bvh", units=scale)
    _same(m2, m3, tol=1e-6)


@pytest.mark.parametrize(
    "mutate,line",
    [
        (lambda s: s.replace("OFFSET 0 10 0", "OFFSET 0 ten 0"), 8),
        (lambda s: s.replace("CHANNELS 3", "CHANNELS 7"), 9),
        (lambda s: s.replace("Frames: 2", "Frames: 3"), 21),
        (lambda s: s.replace("1 90 2 90 0 0 0 0 90", "1 90 2 90 0 0 0 0"), 20),
        (lambda s: s.replace("Xrotation Yrotation Zrotation", "Xrotation Wrotation Zrotation"), 9),
        (lambda s: s.split("MOTION")[0], 16),
    ],
)
def test_malformed_files_name_file_and_line(mutate, line):
    with pytest.raises(BvhError) as e:
        parse_bvh(mutate(SMALL), "bad.bvh")
    assert str(e.value).startswith(f"bad.bvh:{line}:"), str(e.value)


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(BvhError, match="cannot read"):
        read_bvh(tmp_path / "nope.bvh")
    (tmp_path / "empty.bvh").write_text("")
    with pytest.raises(BvhError, match="empty.bvh:1: empty"):
        read_bvh(tmp_path / "empty.bvh")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(max_size=400))
def test_fuzz_garbage_text_only_raises_bvh_error(text):
    try:
        parse_bvh(text, "fuzz.bvh")
    except BvhError as e:
        assert str(e).startswith("fuzz.bvh")


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_fuzz_mutated_file_only_raises_bvh_error(data):
    toks = SMALL.split(" ")
    i = data.draw(st.integers(0, len(toks) - 1))
    toks[i] = data.draw(st.sampled_from(["", "{", "}", "JOINT", "End", "nan", "1e999", "-3", "MOTION", "ROOT x {", "\n"]))
    try:
        m, _ = parse_bvh(" ".join(toks), "fuzz.bvh")
    except BvhError:
        return
    assert torch.isfinite(m.lrot).all() and torch.isfinite(m.lpos).all()


def test_deep_nesting_does_not_recurse():
    text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "".join(
        f"JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for i in range(3000)
    )
    with pytest.raises(BvhError):
        parse_bvh(text, "deep.bvh")


def test_formatted_text_is_valid_default_layout():
    m = random_motion(seconds=1.0, seed=2)
    text = format_bvh(m)
    assert text.startswith("HIERARCHY\nROOT Hips") and "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" in text
    m2, _ = parse_bvh(text, "x.bvh", units="m")
    _same(m, m2)
    assert math.isclose(m2.fps, 20.0)


def test_odd_but_valid_files_that_importers_accept():
    base = format_bvh(random_motion(seconds=1.0, fps=30.0), BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    variants = {
        "byte-order mark": "\ufeff" + base,
        "tab after Frame Time:": base.replace("Frame Time: ", "Frame Time:\t"),
        "tab inside Frame Time": base.replace("Frame Time:", "Frame\tTime:"),
        "lower-case keywords": base.replace("HIERARCHY", "hierarchy").replace("MOTION", "Motion").replace("ROOT", "root")
        .replace("JOINT", "joint").replace("OFFSET", "offset").replace("CHANNELS", "channels").replace("Frames:", "FRAMES:")
        .replace("Zrotation", "ZROTATION"),
        "CRLF line ends": base.replace("\n", "\r\n"),
        "MOTION inside a joint name": base.replace("JOINT Spine", "JOINT SpineMOTION", 1),
    }
    ref, _ = parse_bvh(base)
    for label, text in variants.items():
        motion, _ = parse_bvh(text, label)
        assert motion.num_frames == ref.num_frames and motion.fps == ref.fps, label
        assert torch.allclose(motion.lrot, ref.lrot, atol=1e-6), label


@pytest.mark.parametrize("frame_time", ["5e-324", "1000", "0", "-0.03", "nan"])
def test_frame_times_out_of_range_are_one_line(frame_time):
    base = format_bvh(random_motion(seconds=0.5, fps=30.0), BvhLayout.default(CANONICAL.skeleton))
    text = re.sub(r"Frame Time:.*", f"Frame Time: {frame_time}", base)
    with pytest.raises(BvhError, match=r"clip.bvh:\d+: expected a frame time from 0.0001 to 1 s") as e:
        parse_bvh(text, "clip.bvh")
    assert "\n" not in str(e.value)
