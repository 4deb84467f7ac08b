import cv2
import numpy as np
import pytest
import torch

from motioncore.bvh import BvhError, write_bvh
from motioncore.render import Panel, render_frame, render_video
from motioncore.retarget import from_canonical, make_rig
from motioncore.skeleton import CANONICAL
from testkit.motions import CANONICAL_NAMES_MAP, bandai_like_skeleton, random_motion
from video2style.preview import preview_bvh_files

SK = CANONICAL.skeleton


def _panel(seconds=1.0, shift=0.0, label="synthetic"):
    pos = random_motion(seconds=seconds, seed=1, amplitude=0.15).global_positions()
    return Panel(pos + torch.tensor([shift, 0.0, 0.0]), SK.parents, label, names=SK.names)


def _read(path):
    cap = cv2.VideoCapture(str(path))
    assert cap.isOpened()
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    return frames


def _figure_mask(img):
    """Pixels of the (saturated red / blue) left and right bones; grid, text and background are grey."""
    return cv2.cvtColor(img, cv2.COLOR_BGR2HSV)[..., 1] > 100


def test_video_has_one_frame_per_time_step_and_panel_layout(tmp_path):
    panels = [_panel(1.0), _panel(0.5, label="short")]  # 20 and 10 frames at 20 fps
    out = render_video(panels, tmp_path / "sub" / "a.mp4", fps=20, size=(96, 80), progress=False)
    frames = _read(out)
    assert len(frames) == 20
    assert frames[0].shape == (80, 192, 3)
    assert int(cv2.VideoCapture(str(out)).get(cv2.CAP_PROP_FRAME_COUNT)) == 20
    assert sorted(p.name for p in out.parent.iterdir()) == ["a.mp4"]  # no temp file left behind
    for f in (frames[0], frames[-1]):  # the short panel holds its last frame, still drawn
        assert _figure_mask(f[:, :96]).sum() > 30 and _figure_mask(f[:, 96:]).sum() > 30


def test_camera_follows_a_figure_far_from_the_origin():
    img = render_frame([_panel(), _panel(shift=40.0)], 5, size=(160, 160))
    for k in range(2):
        ys, xs = np.nonzero(_figure_mask(img[:, 160 * k : 160 * (k + 1)]))
        assert len(xs) > 50
        assert abs(xs.mean() - 80) < 40 and abs(ys.mean() - 80) < 50


def test_nan_frames_draw_no_pose_and_no_figure():
    pos = random_motion(seconds=0.5, seed=2).global_positions()
    pos[3] = float("nan")
    panel = Panel(pos, SK.parents, "gappy", names=SK.names)
    assert _figure_mask(render_frame([panel], 2, size=(128, 128))).sum() > 30
    no_pose = render_frame([panel], 3, size=(128, 128))
    assert _figure_mask(no_pose).sum() < 30 and (no_pose.min(axis=2) < 200).any()  # text only


def test_bad_shapes_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match="expected positions"):
        Panel(torch.zeros(5, 3, 2), [-1, 0, 1], "x")
    with pytest.raises(ValueError, match="expected"):
        Panel(torch.zeros(5, 4, 3), [-1, 0, 1], "x")
    with pytest.raises(ValueError, match="even"):
        render_video([_panel(0.2)], tmp_path / "a.mp4", fps=20, size=(97, 80), progress=False)
    with pytest.raises(ValueError, match="at least one panel"):
        render_frame([], 0)


@pytest.fixture
def bvh_files(tmp_path):
    canon = random_motion(seconds=1.0, seed=4, amplitude=0.15)
    write_bvh(tmp_path / "canon.bvh", canon)
    bandai = from_canonical(random_motion(seconds=1.5, seed=5, amplitude=0.15), make_rig(bandai_like_skeleton(), joint_map=CANONICAL_NAMES_MAP))
    write_bvh(tmp_path / "bandai.bvh", bandai)
    return [tmp_path / "canon.bvh", tmp_path / "bandai.bvh"]


@pytest.mark.parametrize("canonical", [False, True])
def test_preview_bvh_files(tmp_path, bvh_files, canonical):
    out = preview_bvh_files(bvh_files, tmp_path / "preview.mp4", canonical=canonical, size=(96, 96))
    frames = _read(out)
    assert len(frames) == 30  # the longest clip, at the first clip's 20 fps
    assert frames[0].shape == (96, 192, 3)
    for f in (frames[0], frames[-1]):
        assert _figure_mask(f[:, :96]).sum() > 30 and _figure_mask(f[:, 96:]).sum() > 30


def test_preview_resamples_to_the_given_fps(tmp_path, bvh_files):
    out = preview_bvh_files(bvh_files[:1], tmp_path / "p.mp4", fps=10, size=(64, 64))
    assert len(_read(out)) == 11  # 20 frames at 20 fps span 0.95 s: 11 frames at 10 fps


def test_preview_reports_the_broken_file(tmp_path, bvh_files):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n")
    with pytest.raises(BvhError, match="bad.bvh:4"):
        preview_bvh_files([bvh_files[0], bad], tmp_path / "p.mp4")
    assert not (tmp_path / "p.mp4").exists()


def test_eye_sets_the_view_a_rod_along_z_is_long_from_the_side_and_short_from_the_front():
    j = 6
    rod = torch.zeros(3, j, 3)
    rod[:, :, 1] = 0.85
    rod[:, :, 2] = torch.linspace(-0.5, 0.5, j)
    names = [f"Bone{k}_L" for k in range(j)]

    def width(eye):
        img = render_frame([Panel(rod, [-1, 0, 1, 2, 3, 4], "rod", names=names, eye=eye)], 1, size=(200, 200))
        xs = np.nonzero(_figure_mask(img))[1]
        return xs.max() - xs.min()

    assert width((3.3, 0.0, 0.0)) > 4 * width((0.01, 0.0, 3.3))
    for bad in ((0.0, 2.0, 0.0), (1.0, 2.0), (float("nan"), 0.0, 1.0)):
        with pytest.raises(ValueError, match="expected eye"):
            Panel(rod, [-1, 0, 1, 2, 3, 4], "rod", eye=bad)
