"""The second unseen-style protocol: Bandai-1 styles that no model, cache or choice of the project has seen.

``../shared/data/bandai1-unseen-dev-styles.tar.xz`` holds five styles (angry, sad, proud, childish, musical), 11
clips each over ten actions. Each style is learned from its ``dataset-1_walk_<style>_001`` clip and applied to
the neutral Bandai-1 clip (``dataset-1_<action>_normal_001``, from ``bandai1-seen-styles.tar.xz``) of each of the
ten actions (:data:`DEV_ACTIONS`). Two judges that share no network with the method read the results
(:func:`fit_judges`), both :class:`evaluation.judge.HandJudge` over hand-made features fitted on the *other* real
Bandai-1 clips (every clip of both archives but the five examples):

- the style judge over :func:`evaluation.judge.judge_features`, classes: the five dev styles and the six seen
  Bandai-1 styles (chance 1 / 11);
- the action judge over :func:`action_features` (the style features plus the root's mean velocity and turning in
  its own facing frame, so walks forward, left, right and back differ), classes: the ten actions.

These clips are for choosing settings and judging only: nothing here trains a model the method uses (the judges
are the protocol's own and never reach learning or apply).
"""
from __future__ import annotations

import re
import tarfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import torch

from evaluation.judge import HandJudge, judge_features
from motioncore.representation import FEATURES

DEV_STYLES = ("angry", "sad", "proud", "childish", "musical")
DEV_ACTIONS = ("walk", "walk-back", "walk-left", "walk-right", "run", "dash", "bow", "bye", "byebye", "guide")
WALKS = ("walk", "walk-back", "walk-left", "walk-right")
_NAME = re.compile(r"dataset-1_(?P<action>[a-z-]+?)_(?P<style>[a-z]+)_(?P<num>\d+)\.bvh$")


@dataclass(frozen=True)
class RealClip:
    """A real Bandai-1 clip on the canonical skeleton: ``raw`` features ``(T, D)`` (unnormalised)."""

    name: str
    action: str
    style: str
    raw: torch.Tensor


def read_archive(path: Path, actions: Sequence[str] = DEV_ACTIONS) -> list[RealClip]:
    """The Bandai-1 clips of these ``actions`` in a ``.tar.xz`` (either archive), on the canonical skeleton at
    its frame rate, sorted by name."""
    from mlcore.dataset import canonical_features
    from motioncore.skeleton import CANONICAL

    clips = []
    with tarfile.open(path, mode="r:*") as tar:
        for member in tar:
            m = _NAME.search(member.name)
            if not (member.isfile() and m and m["action"] in actions):
                continue
            text = tar.extractfile(member).read().decode("utf-8", errors="replace")
            raw, _ = canonical_features(text, Path(member.name).name, CANONICAL.fps)
            clips.append(RealClip(Path(member.name).name, m["action"], m["style"], raw))
    if not clips:
        raise ValueError(f"{path}: no Bandai-1 clips of {', '.join(actions)} found")
    return sorted(clips, key=lambda c: c.name)


def action_features(raw: torch.Tensor) -> torch.Tensor:
    """What moves, not where it is held: :func:`evaluation.judge.judge_features` of raw features ``(T, D)`` less
    the joints' mean places (a style's posture), with the root's mean ground velocity in its facing frame (x, z;
    m/frame) and mean signed turning (rad/frame) appended. Leave-one-out on the real Bandai-1 clips of the ten
    actions: 85 % with this set, 80 % with the mean places kept (docs/results.md, "Unseen dev styles")."""
    base = judge_features(raw)
    places = FEATURES.positions.stop - FEATURES.positions.start  # judge_features opens with them
    return torch.cat([base[places:], raw[:, FEATURES.root_lvel].double().mean(0).float(),
                      raw[:, FEATURES.root_rvel].double().mean(0).float()])


def example_name(style: str) -> str:
    return f"dataset-1_walk_{style}_001.bvh"


def content_name(action: str) -> str:
    return f"dataset-1_{action}_normal_001.bvh"


@dataclass
class Judges:
    style: HandJudge
    action: HandJudge
    centres: dict[tuple[str, str], torch.Tensor]  # (action, style) -> mean standardised style features of its clips
    loo_style: float  # leave-one-out accuracy of the style judge on the real clips it was fitted on
    loo_action: float


def _loo(feats: torch.Tensor, labels: list[str], classes: list[str]) -> float:
    hits = 0
    for i in range(len(labels)):
        keep = [j for j in range(len(labels)) if j != i]
        judge = HandJudge.fit(feats[keep], [labels[j] for j in keep], classes)
        hits += judge.predict(feats[i:i + 1])[0] == labels[i]
    return hits / len(labels)


def fit_judges(clips: Sequence[RealClip], leave_one_out: bool = True) -> Judges:
    """Both judges fitted on ``clips`` less the five examples (:func:`example_name`), with their leave-one-out
    accuracies on those clips (``leave_one_out`` False: NaN, quicker)."""
    examples = {example_name(s) for s in DEV_STYLES}
    fit = [c for c in clips if c.name not in examples]
    styles = sorted({c.style for c in fit})
    actions = sorted({c.action for c in fit})
    f_style = torch.stack([judge_features(c.raw) for c in fit])
    f_action = torch.stack([action_features(c.raw) for c in fit])
    style_labels, action_labels = [c.style for c in fit], [c.action for c in fit]
    style = HandJudge.fit(f_style, style_labels, styles)
    action = HandJudge.fit(f_action, action_labels, actions)
    z = style.standardize(f_style)
    cells: dict[tuple[str, str], list[int]] = {}
    for i, c in enumerate(fit):
        cells.setdefault((c.action, c.style), []).append(i)
    nan = float("nan")
    return Judges(style, action, {k: z[v].mean(0) for k, v in cells.items()},
                  _loo(f_style, style_labels, styles) if leave_one_out else nan,
                  _loo(f_action, action_labels, actions) if leave_one_out else nan)


# transfer(style name, example raw (T', D), action, content raw (T, D)) -> result raw (T, D)
Transfer = Callable[[str, torch.Tensor, str, torch.Tensor], torch.Tensor]


def run_dev_protocol(transfer: Transfer, clips: Sequence[RealClip], judges: Judges,
                     styles: Sequence[str] = DEV_STYLES, actions: Sequence[str] = DEV_ACTIONS,
                     progress=None) -> dict:
    """Every style of ``styles`` (its walk example) onto the neutral clip of every action; returns ``{"rows":
    [per transfer], "by_style", "by_action", "overall"}``, each summary with ``style`` (share judged the target
    style), ``action`` (share judged their action), ``toward`` (share whose style features moved towards the real
    clips of the action in the target style) and ``moved_cm`` (mean joint displacement from the content)."""
    by_name = {c.name: c for c in clips}
    rows = []
    for style in styles:
        example = by_name[example_name(style)].raw
        for action in actions:
            content = by_name[content_name(action)].raw
            out = transfer(style, example, action, content)
            if out.shape != content.shape:
                raise ValueError(f"transfer of {style} onto {action}: expected {tuple(content.shape)}, got {tuple(out.shape)}")
            f_out, f_in = judge_features(out), judge_features(content)
            read_style = judges.style.predict(f_out[None])[0]
            read_action = judges.action.predict(action_features(out)[None])[0]
            centre = judges.centres.get((action, style))
            toward = None
            if centre is not None:
                d_out = (judges.style.standardize(f_out) - centre).norm()
                toward = bool(d_out < (judges.style.standardize(f_in) - centre).norm())
            pos = FEATURES.positions
            moved = float((out[:, pos] - content[:, pos]).unflatten(-1, (-1, 3)).norm(dim=-1).mean()) * 100
            rows.append({"style": style, "action": action, "read_style": read_style, "read_action": read_action,
                         "style_ok": read_style == style, "action_ok": read_action == action, "toward": toward,
                         "moved_cm": moved})
            if progress:
                progress(f"{style:>9} -> {action:<10} read {read_style:<11} / {read_action:<10} moved {moved:4.1f} cm")
    return {"rows": rows, "by_style": _summary(rows, "style", styles), "by_action": _summary(rows, "action", actions),
            "overall": _summary(rows, None, [None])[None]}


def _summary(rows: list[dict], key: str | None, values: Sequence) -> dict:
    out = {}
    for v in values:
        sel = [r for r in rows if key is None or r[key] == v]
        towards = [r["toward"] for r in sel if r["toward"] is not None]
        out[v] = {"n": len(sel), "style": sum(r["style_ok"] for r in sel) / len(sel),
                  "action": sum(r["action_ok"] for r in sel) / len(sel),
                  "toward": sum(towards) / len(towards) if towards else float("nan"),
                  "moved_cm": sum(r["moved_cm"] for r in sel) / len(sel)}
    return out


def format_dev_table(result: dict, identity: dict | None = None) -> str:
    """Markdown tables per style and per action (shares in %), and the overall row."""
    lines = ["| | style judged % | action judged % | towards % | moved cm |", "|---|---:|---:|---:|---:|"]

    def row(name, s):
        lines.append(f"| {name} | {100 * s['style']:.0f} | {100 * s['action']:.0f} | {100 * s['toward']:.0f} | "
                     f"{s['moved_cm']:.1f} |")

    for k, s in result["by_style"].items():
        row(k, s)
    for k, s in result["by_action"].items():
        row(k, s)
    walks = [r for r in result["rows"] if r["action"] in WALKS]
    if walks:
        lines.append(f"| every walk direction, worst | {100 * min(result['by_action'][a]['style'] for a in WALKS if a in result['by_action']):.0f} | | | |")
    row("**all**", result["overall"])
    if identity is not None:
        row("identity (the content)", identity["overall"])
    return "\n".join(lines)
