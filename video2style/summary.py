"""What apply and batch tell a user about each clip: one short line in plain words, the numbers in ``report.json``.

The line says what was changed, how strongly the style shows (how far the joints moved from the content's
places, on average), how often the feet slide before (the content) and after (the result), how much of that is low
steps (as in the example, where its toes stay low in swing too), and any guard that held the style back. Everything else :func:`video2style.pipeline.apply_file` decided (the motion
encoder's reading, the guards' shares, the sentences of :func:`video2style.pipeline.apply_notes`) goes into
the clip's row of ``report.json`` (:func:`clip_details`).
"""
from __future__ import annotations

import json
from pathlib import Path

PARTS = {"arms": ("Shoulder", "UpperArm", "LowerArm", "Hand"), "legs": ("UpperLeg", "LowerLeg", "Foot", "Toes"),
         "head and spine": ("Spine", "Chest", "Neck", "Head")}
# how strongly the style shows, by the mean distance the joints moved from the content's places (cm)
SHOWS = [(1.0, "barely"), (3.0, "lightly"), (8.0, "clearly"), (float("inf"), "strongly")]


def motion_change(content, result) -> dict:
    """How far ``result`` (a canonical motion, frame for frame with ``content``) moved from ``content``: the mean
    distance of every joint from its place in the content, over frames, in cm (``joints_cm``), per body part
    (``parts_cm``), the part moved most (``most``) and a word for it (``shows``, :data:`SHOWS`)."""
    n = min(content.num_frames, result.num_frames)
    a, b = content.global_positions()[:n], result.global_positions()[:n]
    dist = (a - b).norm(dim=-1).mean(dim=0) * 100  # (J,) cm
    names = content.skeleton.names
    parts = {}
    for part, prefixes in PARTS.items():
        idx = [i for i, name in enumerate(names) if name.split("_")[0] in prefixes]
        if idx:
            parts[part] = round(float(dist[idx].mean()), 2)
    joints = round(float(dist.mean()), 2)
    return {"joints_cm": joints, "parts_cm": parts, "most": max(parts, key=parts.get) if parts else None,
            "shows": next(word for limit, word in SHOWS if joints < limit)}


HELD = 0.995
LOW_STEPS = 0.05  # metres: an example whose toes clear the floor by less in swing takes low steps


def _pct(x: float) -> str:
    return f"{100 * x:.0f}%"


def guards_held(info: dict) -> list[str]:
    """The guards that held the style back on this clip, in a few words each."""
    held = []  # a share that rounds to 100% held nothing back that a user could see
    if info.get("still_share", 1.0) < HELD:
        held.append(f"still-pose guard left out {_pct(1 - info['still_share'])} of the fast change")
    if info.get("arm_motion_share", 1.0) < HELD:
        held.append(f"arms kept their own motion ({_pct(info['arm_motion_share'])} of the style's)")
    if info.get("content_share", 1.0) < HELD:
        held.append(f"scaled to {_pct(info['content_share'])} so the action still reads")
    return held


def file_length(info: dict) -> str:
    """The result's length in its own file's frames and seconds (the canonical frames when the file is a video's)."""
    frames, fps = info.get("file_frames"), info.get("file_fps")
    if frames is None or not fps:
        from motioncore.skeleton import CANONICAL

        frames, fps = info.get("frames"), CANONICAL.fps
    if frames is None:
        return ""
    return f"{frames} frames at {fps:g} fps, {frames / fps:.2f} s"


def clip_line(info: dict) -> str:
    """One short line about one clip's result (``info``: :func:`video2style.pipeline.apply_file`'s)."""
    changed = []
    if info.get("neutralized"):
        changed.append("neutralised first")
    if info.get("tempo", 1.0) != 1.0:
        changed.append(f"played {info['tempo']:.2f}x as fast")
    parts = [file_length(info)] if file_length(info) else []
    change = info.get("change")
    if change:
        most = f", most in the {change['most']}" if change.get("most") else ""
        parts.append(f"style shows {change['shows']} (joints moved {change['joints_cm']:.1f} cm on average{most})")
    if changed:
        parts.append(", ".join(changed))
    if "skating_after" in info:
        parts.append(f"feet slide in {_pct(info['skating_content'])} of frames before, {_pct(info['skating_after'])} after"
                     + _low_steps(info))
        if info.get("feet_cleaned") is False:
            parts.append("feet left as styled (locked, they slid more)")
    held = guards_held(info)
    if held:
        parts.append("held back: " + "; ".join(held))
    return "; ".join(parts)


def _low_steps(info: dict) -> str:
    """What of the result's sliding is low steps, not planted feet sliding (``skating_low_steps``: a foot low and
    fast while the content's is in swing), and whether the example steps that low too (``swing_example``)."""
    low, after = info.get("skating_low_steps", 0.0), info.get("skating_after", 0.0)
    if not after or low < 0.5 * after or _pct(low) == "0%":
        return ""
    swing = info.get("swing_example")
    if swing is not None and swing < LOW_STEPS:
        return f" ({_pct(low)} low steps, as in the example)"
    return f" ({_pct(low)} low steps)"


def clip_details(info: dict) -> dict:
    """The numbers and sentences of one clip's result, for its row of ``report.json``."""
    from video2style.pipeline import apply_notes

    keys = ("input", "output", "preview", "player", "frames", "file_frames", "file_fps", "tempo", "detected",
            "neutralized", "skating_content", "skating_before", "skating_after", "skating_low_steps", "feet_cleaned",
            "swing_example", "swing_result", "still_share", "arm_motion_share",
            "content_share", "rolls_conformed", "change", "seconds", "seconds_transfer", "preview_note", "stream_note")
    row = {k: info[k] for k in keys if k in info}
    row["summary"] = clip_line(info)
    row["notes"] = apply_notes(info)
    row["guards_held"] = guards_held(info)
    return row


def write_report(rows: list[dict], out_dir: Path) -> Path:
    """``out_dir/report.json``: one row per clip (:func:`clip_details`, or an error)."""
    from motioncore.files import atomic_write_text

    path = Path(out_dir) / "report.json"
    atomic_write_text(path, json.dumps(rows, indent=1, default=str) + "\n")
    return path
