"""``video2style skeleton``: which joint of a BVH file plays each canonical role, and why.

A report for people (a table of role -> joint -> how it was decided, the extras, the up axis and
units), a joint map they can edit (``--write-map``), and a picture of the pose that was read with
the roles coloured (``--preview``).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import BvhLayout, read_bvh
from motioncore.files import atomic_write_text
from motioncore.kinematics import fk, rest_positions
from motioncore.motion import Motion
from motioncore.retarget import Rig, make_rig
from motioncore.skeleton import CANONICAL

_UNITS = {1.0: "metres", 0.01: "centimetres", 0.001: "millimetres", 0.0254: "inches"}


@dataclass
class SkeletonReport:
    path: Path
    motion: Motion
    layout: BvhLayout
    rig: Rig

    @property
    def roles(self) -> dict[str, str | None]:
        sk = self.motion.skeleton
        return {r: None if j is None else sk.names[j] for r, j in zip(CANONICAL.skeleton.names, self.rig.mapping)}


def inspect_skeleton(path: str | os.PathLike, joint_map: dict | None = None) -> SkeletonReport:
    """Read a BVH file and map its skeleton (``joint_map`` overrides the roles it names). Raises
    :class:`motioncore.bvh.BvhError` or :class:`motioncore.retarget.RetargetError` with one line."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    motion, layout = read_bvh(path)
    return SkeletonReport(path, motion, layout, make_rig(motion.skeleton, motion, joint_map, source=str(path)))


def _extras_by_role(rep: SkeletonReport) -> dict[str, list[str]]:
    """Joints without a role, grouped under the nearest ancestor that has one ("above Hips" for the rest)."""
    sk = rep.motion.skeleton
    role_of = {j: r for r, j in zip(CANONICAL.skeleton.names, rep.rig.mapping) if j is not None}
    groups: dict[str, list[str]] = {}
    for j in range(sk.num_joints):
        if j in role_of:
            continue
        a = sk.parents[j]
        while a >= 0 and a not in role_of:
            a = sk.parents[a]
        groups.setdefault("above Hips" if a < 0 else f"under {role_of[a]}", []).append(sk.names[j])
    return groups


def report_lines(rep: SkeletonReport) -> list[str]:
    """The human-readable report."""
    sk, rig, h = rep.motion.skeleton, rep.rig, rep.rig.humanoid
    scale = rep.layout.scale
    units = next((n for v, n in _UNITS.items() if abs(scale - v) < 1e-9), None)
    lines = [f"{rep.path}: {sk.num_joints} joints, {rep.motion.num_frames} frames at {rep.motion.fps:g} fps",
             f"units: {units or f'{scale:.4g} m per file unit (unknown units, scaled to a human-sized figure)'}"]
    if h is not None:
        facing = h.forward if h.forward != "?" else "unknown (the feet do not show it)"
        lines.append(f"up axis: {h.up} (hips to head over the clip), facing {facing} (read from the {h.pose})")
    up = quat.mul_vec(quat.inv(rig.basis), torch.tensor([0.0, 1.0, 0.0]))
    lines.append(f"world up in the motion: {'+-'[int(float(up[int(up.abs().argmax())]) < 0)]}{'XYZ'[int(up.abs().argmax())]}")
    lines.append(f"mapping: {rig.map_name}")
    lines.append("")
    lines.append(f"{'role':12s} {'joint':32s} how")
    how = dict(zip(CANONICAL.skeleton.names, h.how)) if h is not None else {}
    user = rig.map_name != "auto"
    for role, name in rep.roles.items():
        decided = how.get(role, "your joint map")
        if user and (h is None or h.joint(role) != rig.mapping[CANONICAL.skeleton.index(role)]):
            decided = "your joint map"
        lines.append(f"{role:12s} {name or '-':32s} {decided}")
    extras = _extras_by_role(rep)
    n = sum(len(v) for v in extras.values())
    lines.append("")
    lines.append(f"extras ({n} joints keep their own animation):" if n else "extras: none")
    for where, names in extras.items():
        shown = ", ".join(names[:8]) + (f", … ({len(names)} in all)" if len(names) > 8 else "")
        lines.append(f"  {where}: {shown}")
    return lines


def write_map(rep: SkeletonReport, out: str | os.PathLike) -> Path:
    """The mapping as a joint-map file (``--joint-map``): ``{"Hips": "pelvis", ..., "Toes_L": null}``."""
    out = Path(out)
    atomic_write_text(out, json.dumps(rep.roles, indent=2) + "\n")
    return out


def write_template(path: str | os.PathLike, out: str | os.PathLike) -> list[str]:
    """For a skeleton the mapping cannot read: a joint map with every role null, to fill in. Returns the
    file's joint names."""
    motion, _ = read_bvh(path)
    atomic_write_text(Path(out), json.dumps(dict.fromkeys(CANONICAL.skeleton.names), indent=2) + "\n")
    return list(motion.skeleton.names)


_ROLE_COLORS = {"L": (40, 40, 215), "R": (200, 120, 20), "C": (40, 140, 40)}  # BGR: left red, right blue, centre green
_EXTRA = (175, 175, 175)


def render_roles(rep: SkeletonReport, out: str | os.PathLike, size: int = 720) -> Path:
    """A picture of the pose the mapping read (the rest pose, or a frame for rigs whose rest pose is not a
    standing pose), Y-up, with each role's joint coloured and labelled and the extras grey."""
    import cv2

    from motioncore.files import atomic_output
    from motioncore.render import Panel, render_frame

    sk, rig = rep.motion.skeleton, rep.rig
    h = rig.humanoid
    if h is not None and (h.pose.startswith("frame ") or h.pose == "joint names") and rep.motion.num_frames:
        t = int(h.pose.split()[1]) if h.pose.startswith("frame ") else 0  # names decided: the first frame
        _, gpos = fk(rep.motion.lrot[t:t + 1], rep.motion.lpos[t:t + 1], sk.parents)
        pos = gpos[0]
    else:
        pos = rest_positions(sk.offsets, sk.parents)
    pos = quat.mul_vec(rig.basis, pos) * rig.scale
    pos = pos - torch.tensor([float(pos[rig.mapping[0], 0]), float(pos[:, 1].min()), float(pos[rig.mapping[0], 2])])
    role_of = {j: r for r, j in zip(CANONICAL.skeleton.names, rig.mapping) if j is not None}
    colors = [_ROLE_COLORS[role_of[j][-1] if role_of[j][-2:] in ("_L", "_R") else "C"] if j in role_of else _EXTRA
              for j in range(sk.num_joints)]
    labels = [role_of.get(j, "") for j in range(sk.num_joints)]
    panel = Panel(pos[None], sk.parents, f"{rep.path.name}: roles", colors=colors, labels=labels)
    img = render_frame([panel], 0, (size, size))
    out = Path(out)
    with atomic_output(out, out.suffix or ".png") as tmp:
        if not cv2.imwrite(str(tmp), img):
            raise RuntimeError(f"{out}: OpenCV cannot write this image format (use .png or .jpg)")
    return out
