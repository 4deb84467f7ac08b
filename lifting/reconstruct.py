"""Tracked landmarks -> canonical 3-D motion: gap filling, low-pass, skeleton fit, root path (torch).

Steps of :func:`lift_track` (after :func:`lifting.tracking.track` has run BlazePose over every frame):

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
   projects the fitted skeleton's limb joints onto them through a pinhole (:mod:`lifting.camera`)
   of assumed field of view (``fov_deg`` across the longer side, 60 deg by default);
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
from dataclasses import dataclass, field

import numpy as np
import torch

from lifting.blazepose.results import POSE_LANDMARKS, TrackResult
from lifting.camera import DEFAULT_FOV_DEG, focal_length, solve_translation
from lifting.filtering import (
    DEFAULT_CUTOFF_HZ,
    interpolate_gaps,
    longest_segment,
    lowpass,
)
from lifting.fit import (
    ANCHORS,
    CAMERA_JOINTS,
    DIRECT,
    blend_paths,
    contact_trajectory,
    floor_level,
    floor_lift,
    floor_tilt,
    foot_clearance,
    head_rotation,
    landmarks_to_joints,
    moving_ground,
    up_rotation,
)
from motioncore import quat
from motioncore.ik_fit import fit_positions
from motioncore.motion import Motion
from motioncore.representation import facing_angle
from motioncore.skeleton import CANONICAL

TRAJECTORIES = ("auto", "contacts", "camera")
MAX_GAP_S = 0.5
MIN_SECONDS = 1.0


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


def usable_span(
    found: np.ndarray,
    fps: float,
    source: str,
    max_gap_s: float = MAX_GAP_S,
    min_seconds: float = MIN_SECONDS,
) -> tuple[int, int]:
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
    Landmarks and paths stay numpy float64; rotations are torch float64 quaternions; the one
    conversion into the torch :class:`Motion` happens in :func:`_assemble`.
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

    fitted = _fit_body(world, fps)
    rel_fit = fitted.global_positions().double().numpy()  # root at the origin, camera-aligned frame
    cam_j = [CANONICAL.skeleton.index(j) for j in CAMERA_JOINTS]
    cam_l = [POSE_LANDMARKS.index(DIRECT[j]) for j in CAMERA_JOINTS]
    focal = focal_length(result.width, result.height, fov_deg)
    root_cam = solve_translation(
        rel_fit[:, cam_j],
        image[:, cam_l],
        np.clip(vis[:, cam_l], 0.05, 1.0),
        focal,
        (0.5 * result.width, 0.5 * result.height),
    )
    root_cam = lowpass(root_cam, fps, cutoff_hz)
    turn, rel_w, root_w = _orient(rel_fit, root_cam, fps, level_floor)

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

    motion = _assemble(fitted, turn, root)
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


def _fit_body(world: np.ndarray, fps: float) -> Motion:
    """Canonical rotations fitted to the joint targets of ``world (T, 33, 3)`` landmarks, root at the origin."""
    joints = landmarks_to_joints(world)
    rel = torch.from_numpy(joints - joints[:, :1])
    head = {CANONICAL.skeleton.index("Head"): head_rotation(world)}
    return fit_positions(rel, fps, anchors=ANCHORS, leaf_rotations=head)


def _orient(
    rel_fit: np.ndarray, root_cam: np.ndarray, fps: float, level_floor: bool
) -> tuple[torch.Tensor, np.ndarray, np.ndarray]:
    """``turn (4,)`` that levels the camera (body axis, then floor) and faces +Z over the first 0.5 s,
    with the joints ``(T, J, 3)`` and root path ``(T, 3)`` turned by it."""
    rel_t, root_t = torch.from_numpy(rel_fit), torch.from_numpy(root_cam)
    up = up_rotation(rel_fit)
    n0 = max(1, min(len(rel_fit), round(0.5 * fps)))
    theta = facing_angle(quat.mul_vec(up, rel_t[:n0]))
    theta0 = math.atan2(float(torch.sin(theta).mean()), float(torch.cos(theta).mean()))
    turn = quat.mul(quat.from_yaw(torch.tensor(-theta0, dtype=torch.float64)), up)
    turned = lambda q: (quat.mul_vec(q, rel_t).numpy(), quat.mul_vec(q, root_t).numpy())
    if level_floor:
        turn = quat.mul(floor_tilt(*turned(turn), fps), turn)
    return turn, *turned(turn)


def _assemble(fitted: Motion, turn: torch.Tensor, root: np.ndarray) -> Motion:
    """The fitted body turned by ``turn (4,)`` on the root path ``root (T, 3)``, lifted where float32
    rounding would put a foot below the floor."""
    lrot = fitted.lrot.clone()
    lrot[:, 0] = quat.mul(turn.float().expand(len(lrot), 4), lrot[:, 0])
    lpos = fitted.lpos.clone()
    lpos[:, 0] = torch.from_numpy(root).float()
    motion = Motion(fitted.skeleton, quat.unroll(lrot, dim=0), lpos, fitted.fps)
    root_f = lpos[:, 0].double().numpy()
    below = -foot_clearance(motion.global_positions().double().numpy() - root_f[:, None], root_f[:, 1]).min(axis=1)
    if (below > 0).any():
        lpos[:, 0, 1] += torch.from_numpy(np.where(below > 0, below + 1e-6, 0.0)).float()
        motion = Motion(fitted.skeleton, motion.lrot, lpos, fitted.fps)
    return motion
