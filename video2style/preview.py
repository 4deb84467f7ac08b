"""Preview BVH files as a side-by-side skeleton video (see :mod:`motioncore.render`)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import read_bvh
from motioncore.motion import Motion, resample
from motioncore.render import Panel, render_video
from motioncore.retarget import (
    RetargetError,
    detect_up_basis,
    make_rig,
    place_on_floor,
    to_canonical,
)
from motioncore.skeleton import CANONICAL

MAX_FPS = 30.0
MAX_PREVIEW_SECONDS = 120.0  # a preview is for looking; a 2-hour take would take longer to render than to apply


def _up_basis(motion: Motion, joint_map: dict[str, str] | None, source: str) -> tuple[torch.Tensor, int]:
    """``(4,)`` rotation making the skeleton Y-up (the rig's basis, else a guess from the first frame)
    and the index of the hips joint (0 when no rig can be built)."""
    try:
        rig = make_rig(motion.skeleton, sample=motion, joint_map=joint_map, source=source)
        return rig.basis, rig.mapping[0]
    except RetargetError:
        pos = motion.global_positions()
        rel = pos[0] - pos[0, 0]
        axis = int((rel.max(0).values - rel.min(0).values).argmax())  # a standing body is tallest along up
        sign = 1.0 if float(rel[:, axis].median()) >= 0 else -1.0  # most joints sit above the root
        top = int((sign * rel[:, axis]).argmax())
        return detect_up_basis(pos[:1], 0, top), 0


def _original_panel(motion: Motion, joint_map: dict[str, str] | None, label: str, source: str) -> Panel:
    """The skeleton as in the file, made Y-up and put on the floor. Joints above the hips (e.g.
    Bandai's ``joint_Root`` ground marker) are left out: they would draw a bone to the origin."""
    basis, hips = _up_basis(motion, joint_map, source)
    sk = motion.skeleton
    in_tree = [j == hips for j in range(sk.num_joints)]
    for j in range(hips + 1, sk.num_joints):
        in_tree[j] = in_tree[j] or in_tree[sk.parents[j]]
    keep = [j for j in range(sk.num_joints) if in_tree[j]]
    new = {j: i for i, j in enumerate(keep)}
    parents = [new.get(sk.parents[j], -1) for j in keep]
    pos = quat.mul_vec(basis, motion.global_positions()[:, keep])
    floor = torch.quantile(pos[..., 1].min(dim=1).values, 0.05)
    pos = pos - pos.new_tensor([0.0, 1.0, 0.0]) * floor
    return Panel(pos, parents, label, names=[sk.names[j] for j in keep])


def preview_bvh_files(
    paths: Sequence[str | os.PathLike],
    out_path: str | os.PathLike,
    canonical: bool = False,
    joint_map: dict[str, str] | None = None,
    fps: float | None = None,
    size: tuple[int, int] = (480, 480),
    notify=None,
) -> Path:
    """Render each BVH file as one panel of an mp4 at ``out_path``; returns the path.

    ``canonical=True`` retargets each clip to the canonical skeleton first. The video runs at
    ``fps``, by default the first clip's rate capped at 30. Raises :class:`BvhError` for a file
    that does not parse and :class:`RetargetError` for one that cannot be retargeted. Clips longer than
    :data:`MAX_PREVIEW_SECONDS` are shown up to there, and ``notify(message)`` says so.
    """
    if not paths:
        raise ValueError("expected at least one BVH path, got 0")
    motions = [read_bvh(p)[0] for p in paths]
    longest = max(m.duration for m in motions)
    if longest > MAX_PREVIEW_SECONDS:
        motions = [m.slice(0, int(MAX_PREVIEW_SECONDS * m.fps)) for m in motions]
        if notify is not None:
            notify(f"note: the preview shows the first {MAX_PREVIEW_SECONDS:g} s of {longest:.0f} s")
    out_fps = float(fps) if fps is not None else min(motions[0].fps, MAX_FPS)
    panels = []
    for path, motion in zip(paths, motions):
        motion = resample(motion, out_fps)
        name, source = Path(path).stem, os.fspath(path)
        if canonical:
            rig = make_rig(motion.skeleton, sample=motion, joint_map=joint_map, source=source)
            m = place_on_floor(to_canonical(motion, rig))
            sk = CANONICAL.skeleton
            panels.append(Panel(m.global_positions(), sk.parents, f"{name} (canonical)", names=sk.names))
        else:
            panels.append(_original_panel(motion, joint_map, name, source))
    return render_video(panels, out_path, out_fps, size)
