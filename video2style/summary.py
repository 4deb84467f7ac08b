"""What apply and batch tell a user about each clip: one short line in plain words, the numbers in ``report.json``.

The line says what was changed, how strongly the style shows (how far the joints moved from the content's
places, on average), how often the feet slide before (the content) and after (the result), how much of that is low
steps (as in the example, where its toes stay low in swing too), and any guard that held the style back. Everything
else apply decided (:class:`video2style.result.ApplyResult`: the motion encoder's reading, the guards' shares, the
sentences of :func:`apply_notes`) goes into the clip's row of ``report.json`` (:func:`clip_details`).
"""
from __future__ import annotations

import json
from pathlib import Path

from video2style.result import ApplyResult

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


def _share(share: float | None) -> float:
    return 1.0 if share is None else share


def guards_held(result: ApplyResult) -> list[str]:
    """The guards that held the style back on this clip, in a few words each."""
    held = []  # a share that rounds to 100% held nothing back that a user could see
    if _share(result.still_share) < HELD:
        held.append(f"still-pose guard left out {_pct(1 - result.still_share)} of the fast change")
    if _share(result.arm_motion_share) < HELD:
        held.append(f"arms kept their own motion ({_pct(result.arm_motion_share)} of the style's)")
    if _share(result.content_share) < HELD:
        held.append(f"scaled to {_pct(result.content_share)} so the action still reads")
    return held


def apply_notes(result: ApplyResult) -> list[str]:
    """What apply decided on its own for one clip, as sentences for a user: bone rolls solved again
    (``rolls_conformed``), the still-pose guard (``still_share``), the arms' hold on a clip done in place
    (``arm_motion_share``) and the content keeper (``content_share``); empty when none of them acted."""
    from video2style.pipeline import ROLLS_NOTE

    notes = []
    if result.rolls_conformed:
        notes.append(f"{ROLLS_NOTE} (the file written keeps its own twist)")
    if _share(result.still_share) < 1.0:
        notes.append(f"the style model barely moves on this clip, so {100 * (1 - result.still_share):.0f}% of its "
                     "fast change was left out (its slow change, the posture, is kept)")
    if _share(result.arm_motion_share) < 1.0:
        notes.append(f"the example travels and this clip stays in place: its arms keep their own motion "
                     f"({100 * result.arm_motion_share:.0f}% of the style's), held where the example holds its arms")
    if _share(result.content_share) < 1.0:
        notes.append(f"style change scaled to {100 * result.content_share:.0f}% so the action still reads as the "
                     "content's")
    return notes


def file_length(result: ApplyResult) -> str:
    """The result's length in its own file's frames and seconds (the canonical frames when the file is a video's)."""
    frames, fps = result.file_frames, result.file_fps
    if frames is None or not fps:
        from motioncore.skeleton import CANONICAL

        frames, fps = result.frames, CANONICAL.fps
    if frames is None:
        return ""
    return f"{frames} frames at {fps:g} fps, {frames / fps:.2f} s"


def clip_line(result: ApplyResult) -> str:
    """One short line about one clip's result."""
    changed = []
    if result.neutralized:
        changed.append("neutralised first")
    if (result.tempo or 1.0) != 1.0:
        changed.append(f"played {result.tempo:.2f}x as fast")
    parts = [file_length(result)] if file_length(result) else []
    change = result.change
    if change:
        most = f", most in the {change['most']}" if change.get("most") else ""
        parts.append(f"style shows {change['shows']} (joints moved {change['joints_cm']:.1f} cm on average{most})")
    if changed:
        parts.append(", ".join(changed))
    if result.skating_after is not None:
        parts.append(f"feet slide in {_pct(result.skating_content)} of frames before, {_pct(result.skating_after)} after"
                     + _low_steps(result))
        if result.feet_cleaned is False:
            parts.append("feet left as styled (locked, they slid more)")
    held = guards_held(result)
    if held:
        parts.append("held back: " + "; ".join(held))
    return "; ".join(parts)


def _low_steps(result: ApplyResult) -> str:
    """What of the result's sliding is low steps, not planted feet sliding (``skating_low_steps``: a foot low and
    fast while the content's is in swing), and whether the example steps that low too (``swing_example``)."""
    low, after = result.skating_low_steps or 0.0, result.skating_after or 0.0
    if not after or low < 0.5 * after or _pct(low) == "0%":
        return ""
    swing = result.swing_example
    if swing is not None and swing < LOW_STEPS:
        return f" ({_pct(low)} low steps, as in the example)"
    return f" ({_pct(low)} low steps)"


def clip_details(result: ApplyResult) -> dict:
    """The numbers and sentences of one clip's result, for its row of ``report.json``: the measured fields
    (:meth:`video2style.result.ApplyResult.reported`), the summary line, the notes and the guards that held."""
    row = result.reported()
    row["summary"] = clip_line(result)
    row["notes"] = apply_notes(result)
    row["guards_held"] = guards_held(result)
    return row


def write_report(rows: list[dict], out_dir: Path) -> Path:
    """``out_dir/report.json``: one row per clip (:func:`clip_details`, or an error)."""
    from motioncore.files import atomic_write_text

    path = Path(out_dir) / "report.json"
    atomic_write_text(path, json.dumps(rows, indent=1, default=str) + "\n")
    return path
