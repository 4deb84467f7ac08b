"""Videos turned in their pixels (filmed upside down, a phone video on its side): refused naming ``--rotate``,
upright with it, and a rotation tag in the file's metadata applied (issue 25).

The landmark checks and the frame turning run everywhere; lifting a render needs the BlazePose models
(skipped cleanly without them, like the other tracker tests).
"""

from __future__ import annotations

import struct
import subprocess
import sys

import cv2
import numpy as np
import pytest

from lifting.blazepose.results import POSE_LANDMARKS
from lifting.render_humanoid import frame_camera, render_frames
from lifting.upright import check_rotation, check_upright, frame_turn, frame_turns
from lifting.video import iter_frames, rotate_frame, video_info
from motioncore.mp4 import write_mp4
from tests.lifting.helpers import H, W, fake_track, standing_landmarks, turned_pixels, waving_motion

CV_TURN = {90: cv2.ROTATE_90_CLOCKWISE, 180: cv2.ROTATE_180, 270: cv2.ROTATE_90_COUNTERCLOCKWISE}


def write_turned(path, frames, turn: int, fps: float = 30.0):
    """``frames`` turned ``turn`` degrees clockwise in their pixels, written to an mp4."""
    turned = [cv2.rotate(f, CV_TURN[turn]) if turn else f for f in frames]
    h, w = turned[0].shape[:2]
    return write_mp4(turned, path, fps, (w, h))


def tag_rotation(src, dst, turn: int) -> None:
    """A copy of the mp4 ``src`` whose track header (tkhd) asks players to show it turned ``turn`` degrees
    clockwise, as a phone does for a video held upright."""
    data = bytearray(src.read_bytes())
    at = data.find(b"tkhd") - 4
    assert at >= 0 and data[at + 8] == 0  # version 0: the matrix sits 48 bytes into the box
    c, s = {0: (1, 0), 90: (0, 1), 180: (-1, 0), 270: (0, -1)}[turn]
    data[at + 48:at + 84] = struct.pack(">9i", c << 16, s << 16, 0, -s << 16, c << 16, 0, 0, 0, 1 << 30)
    dst.write_bytes(bytes(data))


# ---------------------------------------------------------------- no models needed


@pytest.mark.parametrize("turn", [0, 90, 180, 270])
def test_the_persons_turn_is_read_from_the_landmarks(turn):
    pts = turned_pixels(standing_landmarks(), turn)
    assert (frame_turns(pts) == turn).all()
    assert frame_turn(fake_track(pts)) == (turn, 1.0)


@pytest.mark.parametrize(("turn", "fix"), [(90, 270), (180, 180), (270, 90)])
def test_a_turned_person_is_refused_naming_the_rotate_that_fixes_it(turn, fix, tmp_path):
    with pytest.raises(ValueError, match=rf"clip\.mp4: .*run again with --rotate {fix}\b") as info:
        check_upright(fake_track(turned_pixels(standing_landmarks(), turn)), tmp_path / "clip.mp4")
    assert "\n" not in str(info.value)
    # the fix applied to the turned landmarks gives an upright person
    upright = turned_pixels(turned_pixels(standing_landmarks(), turn), fix, *((360, 640) if turn % 180 else (640, 360)))
    check_upright(fake_track(upright), tmp_path / "clip.mp4")


def test_upright_bending_and_a_few_turned_frames_pass(tmp_path):
    pts = standing_landmarks(10)
    bent = pts.copy()  # bending over: shoulders level with the hips, well above the ankles
    for side in ("left", "right"):
        bent[:, POSE_LANDMARKS.index(f"{side}_shoulder"), :2] = (420, 200)
    mixed = np.concatenate([pts[:4], bent[:3], turned_pixels(pts[:3], 180)])  # a cartwheel's upside-down frames
    found = np.ones(len(mixed), bool)
    check_upright(fake_track(mixed, found), tmp_path / "v.mp4")
    mixed[:4] = np.nan  # frames without the person do not vote
    found[:4] = False
    with pytest.raises(ValueError, match="--rotate 180"):  # 3 turned of 6 tracked is not a majority, 3 of 5 is
        check_upright(fake_track(np.concatenate([mixed, turned_pixels(pts[:1], 180)]), np.r_[found, True]), "v.mp4")
    check_upright(fake_track(np.full_like(pts, np.nan), np.zeros(10, bool)), "v.mp4")  # nobody tracked: no opinion


def test_rotate_values_are_checked():
    assert [check_rotation(r) for r in (None, 0, 90, 180, 270)] == [0, 0, 90, 180, 270]
    for bad in (45, -90, 360, True, "90"):
        with pytest.raises(ValueError, match="--rotate expected one of 0, 90, 180, 270"):
            check_rotation(bad)
    with pytest.raises(ValueError, match="expected landmark pixels"):
        frame_turns(np.zeros((4, 17, 2)))


def test_frames_are_turned_clockwise_and_the_info_follows(tmp_path):
    frame = np.zeros((360, 640, 3), np.uint8)
    frame[:40, :80] = 255  # a white block top left
    video = write_turned(tmp_path / "block.mp4", [frame] * 3, 0)
    for turn, corner in ((0, (0, 0)), (90, (0, -1)), (180, (-1, -1)), (270, (-1, 0))):
        _, n, w, h = video_info(video, turn)
        frames = [f for _, _, f in iter_frames(video, turn)]
        assert n == 3 and frames[0].shape[:2] == (h, w) == ((640, 360) if turn % 180 else (360, 640))
        assert frames[0][corner].mean() > 200  # the block went where a clockwise turn takes it
        np.testing.assert_array_equal(rotate_frame(frames[0], 0), frames[0])


def test_a_rotation_tag_in_the_file_is_applied(tmp_path):
    """A phone stores the pixels on their side with a tag saying how to show them: OpenCV's frames are
    the shown ones (so the landmarks, the lift and the preview see the person as the phone's user did)."""
    frame = np.zeros((360, 640, 3), np.uint8)
    frame[:40, :80] = 255
    plain = write_turned(tmp_path / "plain.mp4", [frame] * 3, 0)
    tag_rotation(plain, tmp_path / "tagged.mp4", 90)
    _, _, w, h = video_info(tmp_path / "tagged.mp4")
    first = next(iter_frames(tmp_path / "tagged.mp4"))[2]
    assert (w, h) == (360, 640) and first.shape[:2] == (640, 360) and first[0, -1].mean() > 200


def test_rotate_is_refused_for_a_bvh(tmp_path):
    from video2style.pipeline import read_clip

    bvh = tmp_path / "clip.bvh"
    bvh.write_text("HIERARCHY\n")
    with pytest.raises(ValueError, match="clip.bvh: --rotate turns a video's frames"):
        read_clip(bvh, rotate=90)


def test_cli_offers_rotate_on_the_video_commands():
    from lifting.upright import ROTATIONS
    from video2style.cli import build_parser

    parser = build_parser()
    for argv in (["pose", "v.mp4"], ["learn", "v.mp4"], ["batch", "videos", "--content", "c", "-o", "o"]):
        assert parser.parse_args([*argv, "--rotate", "270"]).rotate == 270
        assert parser.parse_args(argv).rotate is None
    choices = next(a for a in parser._subparsers._group_actions[0].choices["pose"]._actions if a.dest == "rotate").choices
    assert tuple(choices) == ROTATIONS
    with pytest.raises(SystemExit):
        parser.parse_args(["pose", "v.mp4", "--rotate", "45"])


# ---------------------------------------------------------------- with the models


@pytest.fixture(scope="module")
def frames(blazepose_models):
    """The 1.6 s waving render of test_pipeline, 640x360, as frames."""
    motion = waving_motion()
    cam = frame_camera(motion.global_positions().numpy(), 35.0, width=W, height=H)
    return list(render_frames(motion, cam))


def head_above_feet(motion) -> float:
    """Mean height of the head over the lower ankle, metres (positive: upright)."""
    from motioncore.skeleton import CANONICAL

    sk = CANONICAL.skeleton
    p = motion.global_positions().numpy()
    feet = np.minimum(p[:, sk.index("Foot_L"), 1], p[:, sk.index("Foot_R"), 1])
    return float((p[:, sk.index("Head"), 1] - feet).mean())


@pytest.mark.slow
@pytest.mark.parametrize(("turn", "fix"), [(90, 270), (180, 180)])
def test_a_turned_video_is_refused_then_upright_with_rotate(frames, tracker, tmp_path, turn, fix):
    from lifting.lift import lift_video

    video = write_turned(tmp_path / f"turned{turn}.mp4", frames, turn)
    with pytest.raises(ValueError, match=rf"turned{turn}\.mp4: .*--rotate {fix}\b"):
        lift_video(video, tracker=tracker)
    fixed = lift_video(video, tracker=tracker, rotate=fix)
    assert head_above_feet(fixed.motion) > 1.0
    assert head_above_feet(lift_video(video, tracker=tracker, rotate=0).motion) < 1.0  # 0: taken as it is


def test_a_tagged_phone_video_is_upright_without_rotate(frames, tracker, tmp_path):
    stored = write_turned(tmp_path / "stored.mp4", frames, 270)  # pixels on their side, tag turns them back
    tag_rotation(stored, tmp_path / "phone.mp4", 90)
    from lifting.lift import lift_video

    assert head_above_feet(lift_video(tmp_path / "phone.mp4", tracker=tracker).motion) > 1.0


@pytest.mark.slow
def test_pose_cli_refuses_an_upside_down_video_in_one_line(frames, tmp_path):
    video = write_turned(tmp_path / "flipped.mp4", frames, 180)
    run = subprocess.run([sys.executable, "-m", "video2style", "pose", str(video), "-o", str(tmp_path / "f.bvh"),
                          "--preview", str(tmp_path / "f.mp4"), "-q"], capture_output=True, text=True, timeout=300,
                         check=False)
    assert run.returncode != 0
    assert "flipped.mp4" in run.stderr and "--rotate 180" in run.stderr
    assert len([line for line in run.stderr.splitlines() if line.strip()]) == 1, run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["flipped.mp4"]  # nothing written
    run = subprocess.run([sys.executable, "-m", "video2style", "pose", str(video), "-o", str(tmp_path / "f.bvh"),
                          "--preview", str(tmp_path / "f.mp4"), "-q", "--rotate", "180"],
                         capture_output=True, text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    from motioncore.bvh import read_bvh

    assert head_above_feet(read_bvh(tmp_path / "f.bvh")[0]) > 1.0
    cap = cv2.VideoCapture(str(tmp_path / "f.mp4"))
    assert cap.get(cv2.CAP_PROP_FRAME_COUNT) == len(frames)
    cap.release()
