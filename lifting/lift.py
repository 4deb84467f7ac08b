"""Video -> canonical 3-D motion: BlazePose tracking, gap filling, low-pass, skeleton fit, root path.

Steps of :func:`lift_track` (after :func:`track` has run BlazePose over every frame):

1. the longest run of frames with the person whose gaps are at most ``max_gap_s`` (default
   0.5 s); gaps inside it are filled by linear interpolation; less than ``min_seconds`` (1 s)
   is an error;
2. the landmarks (world and image) are low-passed with a zero-phase Butterworth filter
   (:func:`lifting.filtering.lowpass`, 3 Hz by default after Hu et al. §4.6.1, order 4 run
   forward and backward): the filter acts on the *landmark positions*, so joints, head frame
   and camera solve are all smooth;
3. canonical joint targets from the world landmarks (:func:`lifting.fit.landmarks_to_joints`)
   and rotations fitted with constant canonical bone lengths (:func:`motioncore.ik_fit.fit_positions`);
4. the root's camera-space path from the image landmarks: per frame, the translation that
   projects the fitted skeleton's limb joints onto them through a pinhole of assumed field of
   view (``fov_deg`` across the longer side, 60 deg by default);
5. camera pitch and roll removed so the median body axis is vertical, then refined so the floor
   under the feet that are down is level (when the person moves around enough to show it);
6. the root path. The *contact path* keeps feet that are down in place: horizontally the root
   moves by minus the stance foot's motion relative to it (interpolated through flight), and
   stands the stance leg's height above the floor. ``trajectory="auto"`` (default) uses the
   camera path below 0.5 Hz and the contact path above it (right on average, no foot skating),
   except when the legs walk but the camera path stays put (a treadmill, a camera following
   the person): then the contact path alone. ``"contacts"`` and ``"camera"`` force one;
7. turned to face +Z at the start (mean facing over the first 0.5 s) with the root's start at
   x = z = 0, and lifted so that no foot is below y = 0 in any frame.

The motion keeps the **video's frame rate** (callers resample, e.g. to the canonical 20 fps).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from lifting.blazepose.landmarks import POSE_LANDMARKS
from lifting.blazepose.tracker import PoseFrame, PoseTracker, TrackResult
from lifting.filtering import (
    DEFAULT_CUTOFF_HZ,
    interpolate_gaps,
    longest_segment,
    lowpass,
)
from lifting.fit import (
    ANCHORS,
    CAMERA_JOINTS,
    DEFAULT_FOV_DEG,
    DIRECT,
    blend_paths,
    contact_trajectory,
    floor_level,
    floor_lift,
    floor_tilt,
    focal_length,
    foot_clearance,
    head_rotation,
    landmarks_to_joints,
    moving_ground,
    solve_translation,
    up_rotation,
)
from lifting.video import iter_frames, prefetched, video_info
from motioncore import quat
from motioncore.ik_fit import fit_positions
from motioncore.motion import Motion, Span, check_span
from motioncore.representation import facing_angle
from motioncore.skeleton import CANONICAL

Progress = bool | Callable[[str], None] | None
TRAJECTORIES = ("auto", "contacts", "camera")
MAX_GAP_S = 0.5
MIN_SECONDS = 1.0
TRUNCATED_FRACTION = 0.9  # fewer decoded frames than this share of the container's count: truncated


@dataclass
class LiftResult:
    """A lifted clip. ``motion``: canonical, the video's fps, frames ``start..stop-1`` of the video.
    ``track``: BlazePose on every frame.
    ``filled``: frames inside the span whose pose was interpolated. ``info``: numbers for reports."""

    motion: Motion
    track: TrackResult
    start: int
    stop: int
    filled: int
    info: dict = field(default_factory=dict)


class _Reporter:
    """Progress in frames: a tqdm bar (``True``), a callable given a line every ~10 %, or nothing."""

    def __init__(self, progress: Progress, total: int, label: str):
        self.callback = progress if callable(progress) else None
        self.total, self.label, self.done, self.next_report = total, label, 0, 0
        self.bar = None
        if progress is True:
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="frame", desc=label)

    def update(self, n: int = 1) -> None:
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.callback is not None and (self.done >= self.next_report or self.done == self.total):
            self.callback(f"{self.label}: frame {self.done}/{self.total}")
            self.next_report = self.done + max(1, self.total // 10)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def track(path: str | Path, progress: Progress = None, tracker: PoseTracker | None = None,
          span: Span = (None, None)) -> TrackResult:
    """BlazePose over every frame of a video (frames are decoded one at a time).

    ``span = (start, end)`` seconds: only frames with ``start <= time < end`` are tracked (None: open end).
    Raises ValueError naming the file for a missing file, one that is not a video, one without
    frames, one that decodes to clearly fewer frames than its header promises (truncated), and a
    span that holds no frame.
    """
    path = Path(path)
    start_s, end_s = check_span(span, str(path))
    fps, expected, width, height = video_info(path)
    tracker = tracker if tracker is not None else PoseTracker()
    tracker.reset()
    frames: list[PoseFrame] = []
    times: list[float] = []
    decoded = 0
    bar = _Reporter(progress, expected, f"{path.name}: tracking")
    try:
        for _, time_s, frame in prefetched(iter_frames(path)):  # decoding overlaps tracking
            decoded += 1
            bar.update()
            if (start_s is not None and time_s < start_s - 1e-9) or (end_s is not None and time_s >= end_s - 1e-9):
                continue
            frames.append(tracker.process(frame, time_s))
            times.append(time_s)
    finally:
        bar.close()
    if decoded < TRUNCATED_FRACTION * expected - 1:
        raise ValueError(f"{path}: the video looks truncated: decoded {decoded} of the {expected} frames its header lists")
    if not frames:
        raise ValueError(f"{path}: --start/--end select no frames (the video is {decoded / fps:.2f} s long)")
    return TrackResult.stack(frames, times, fps, width, height)


def usable_span(found: np.ndarray, fps: float, source: str, max_gap_s: float = MAX_GAP_S,
                min_seconds: float = MIN_SECONDS) -> tuple[int, int]:
    """``[start, stop)`` of the longest tracked run (gaps up to ``max_gap_s``), or ValueError."""
    n = len(found)
    if not found.any():
        raise ValueError(f"{source}: no person found in any of the {n} frames")
    start, stop = longest_segment(found, max(0, round(max_gap_s * fps)))
    need = max(2, math.ceil(min_seconds * fps))
    if stop - start < need:
        raise ValueError(
            f"{source}: too little usable motion: the person was tracked for only {stop - start} frames "
            f"({(stop - start) / fps:.2f} s) in a row ({int(found.sum())} of {n} frames in all); need at least {min_seconds:g} s"
        )
    return start, stop


def lift_track(
    result: TrackResult,
    source: str = "video",
    cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
    fov_deg: float = DEFAULT_FOV_DEG,
    trajectory: str = "auto",
    max_gap_s: float = MAX_GAP_S,
    min_seconds: float = MIN_SECONDS,
    level_floor: bool = True,
) -> LiftResult:
    """Landmarks of a tracked video -> :class:`LiftResult` (see the module docstring for the steps).

    ``cutoff_hz`` None or 0 skips the low-pass. ``source`` names the file in error messages.
    """
    if trajectory not in TRAJECTORIES:
        raise ValueError(f"expected trajectory in {TRAJECTORIES}, got {trajectory!r}")
    fps = float(result.fps)
    found = result.found & np.isfinite(result.world).all(axis=(1, 2)) & np.isfinite(result.image).all(axis=(1, 2))
    start, stop = usable_span(found, fps, source, max_gap_s, min_seconds)
    ok = found[start:stop]
    world = interpolate_gaps(result.world[start:stop], ok)
    image = interpolate_gaps(result.image[start:stop, :, :2], ok)
    vis = interpolate_gaps(np.nan_to_num(result.visibility[start:stop], nan=0.0), ok)
    world, image = lowpass(world, fps, cutoff_hz), lowpass(image, fps, cutoff_hz)

    sk = CANONICAL.skeleton
    joints = landmarks_to_joints(world)
    rel = joints - joints[:, :1]
    head = torch.from_numpy(head_rotation(world))
    fitted = fit_positions(torch.from_numpy(rel), fps, anchors=ANCHORS, leaf_rotations={sk.index("Head"): head})
    rel_fit = fitted.global_positions().double().numpy()  # root at the origin, camera-aligned frame

    cam_j = [sk.index(j) for j in CAMERA_JOINTS]
    cam_l = [POSE_LANDMARKS.index(DIRECT[j]) for j in CAMERA_JOINTS]
    focal = focal_length(result.width, result.height, fov_deg)
    root_cam = solve_translation(rel_fit[:, cam_j], image[:, cam_l], np.clip(vis[:, cam_l], 0.05, 1.0), focal,
                                 (0.5 * result.width, 0.5 * result.height))
    root_cam = lowpass(root_cam, fps, cutoff_hz)

    # Level the camera, then turn to face +Z at the start.
    up = torch.from_numpy(up_rotation(rel_fit))
    n0 = max(1, min(len(rel_fit), round(0.5 * fps)))
    theta = facing_angle(quat.mul_vec(up, torch.from_numpy(rel_fit[:n0])))
    theta0 = math.atan2(float(torch.sin(theta).mean()), float(torch.cos(theta).mean()))
    turn = quat.mul(quat.from_yaw(torch.tensor(-theta0, dtype=torch.float64)), up)
    rel_w = quat.mul_vec(turn, torch.from_numpy(rel_fit)).numpy()
    root_w = quat.mul_vec(turn, torch.from_numpy(root_cam)).numpy()
    if level_floor:
        tilt = torch.from_numpy(floor_tilt(rel_w, root_w, fps))
        turn = quat.mul(tilt, turn)
        rel_w = quat.mul_vec(turn, torch.from_numpy(rel_fit)).numpy()
        root_w = quat.mul_vec(turn, torch.from_numpy(root_cam)).numpy()

    contact, contacts = contact_trajectory(rel_w, root_w, fps)
    contact[:, 1] = lowpass(contact[:, 1], fps, cutoff_hz)
    ground_moves = moving_ground(contact, root_w, fps)
    if trajectory == "auto":
        root = contact if ground_moves else blend_paths(contact, root_w, fps)
    elif trajectory == "contacts":
        root = contact
    else:
        root = root_w.copy()
        root[:, 1] -= floor_level(foot_clearance(rel_w, root_w[:, 1]), fps)
    root[:, [0, 2]] -= root[0, [0, 2]]
    lift = floor_lift(rel_w, root[:, 1], fps)
    root[:, 1] += lift

    lrot = fitted.lrot.clone()
    lrot[:, 0] = quat.mul(turn.float().expand(len(lrot), 4), lrot[:, 0])
    lpos = fitted.lpos.clone()
    lpos[:, 0] = torch.from_numpy(root).float()
    motion = Motion(sk, quat.unroll(lrot, dim=0), lpos, fps)
    # Rounding (float32 FK) must not put a foot below the floor either.
    below = -foot_clearance(motion.global_positions().double().numpy() - lpos[:, None, 0].double().numpy(),
                            lpos[:, 0, 1].double().numpy()).min(axis=1)
    if (below > 0).any():
        lpos[:, 0, 1] += torch.from_numpy(np.maximum(below, 0.0) + 1e-6).float() * torch.from_numpy(below > 0).float()
        motion = Motion(sk, motion.lrot, lpos, fps)
    y = torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64)
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(quat.mul_vec(quat.inv(turn), y) @ y)))))
    info = {
        "frames": len(found),
        "found": int(result.found.sum()),
        "start": start,
        "stop": stop,
        "filled": int((~ok).sum()),
        "fps": fps,
        "cutoff_hz": cutoff_hz or 0.0,
        "fov_deg": fov_deg,
        "trajectory": trajectory,
        "camera_tilt_deg": tilt,
        "floor_lift_max_m": float(lift.max()),
        "contact_fraction": float((contacts.sum(axis=1) > 0.5).mean()),
        "moving_ground": ground_moves,
        "distance_m": float(np.linalg.norm(np.diff(root[:, [0, 2]], axis=0), axis=1).sum()),
    }
    return LiftResult(motion, result, start, stop, int((~ok).sum()), info)


def lift_video(path: str | Path, progress: Progress = None, cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
               tracker: PoseTracker | None = None, span: Span = (None, None), **options) -> LiftResult:
    """:func:`track` + :func:`lift_track` for a video file (``options`` go to :func:`lift_track`);
    ``span``: ``(start, end)`` seconds of the video to use."""
    t0 = time.perf_counter()
    result = track(path, progress, tracker, span)
    t1 = time.perf_counter()
    lifted = lift_track(result, str(path), cutoff_hz, **options)
    lifted.info["track_s"] = t1 - t0
    lifted.info["lift_s"] = time.perf_counter() - t1
    return lifted


def video_to_motion(path: str | Path, progress: Progress = None, cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
                    span: Span = (None, None), **options) -> Motion:
    """A video of one person -> canonical :class:`Motion` at the **video's frame rate** (resample
    to 20 fps for the models). ``progress``: True for a bar in frames, a callable taking a line of
    text, or None/False. Raises ValueError (one line, naming the file) for unusable videos."""
    return lift_video(path, progress, cutoff_hz, span=span, **options).motion
