"""Style transfer evaluation protocol on the Bandai-2 test split, after Hu et al. 2024 §4.2.

Selection (:func:`select_protocol`, seeded): only the *non-mirrored* Bandai-2 test originals
(the split holds 6 per content x style cell: 420 clips). For each content, ``per_content``
content clips are drawn spread evenly over their source styles (styles in a shuffled cycle, a
random clip of the cell each time); each is transferred to every *other* style, each time with
``examples_per_style`` style examples drawn without replacement from the test originals of that
style (any content). Full: 9 per content x 6 other styles x 7 examples = 3780 transfers, Hu et
al.'s count; ``quick``: 2 per content x 6 x 1 = 120.

A method is ``transfer(content_feats (T, D), style_example (T', D), style_label, content_label) -> (T, D)``,
features normalised with the cache's statistics. :func:`run_protocol` reports per method:

- ``fmd``: Fréchet distance between the content classifier's pooled features of the 420 real
  test originals and of the generated set (depends on the set sizes: compare equal protocols);
- ``cra`` / ``sra``: content / style classifier accuracy against the content clip's content and
  the target style;
- ``skating``: :func:`motioncore.skating.foot_skating_ratio` of the generated motions' decoded
  positions (the reference row gives the real test clips' ratio under the same rule);
- ``contact_agreement``: foot contact agreement between each content clip and its output;
- ``judge_sra`` / ``judge_toward``: the independent hand-feature judge's reading (:mod:`evaluation.judge`);
- ``sec_per_transfer``: mean wall time of one ``transfer`` call.
"""
from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import torch
from tqdm import tqdm

from evaluation.classifiers import (
    MotionClassifier,
    default_weights,
    load_classifier,
    run_batched,
)
from evaluation.judge import judge_scores
from evaluation.metrics import (
    foot_contact_agreement,
    frechet_distance,
    limb_stray,
)
from mlcore.captions import BANDAI2_CONTENTS, STYLES
from mlcore.dataset import ClipRecord, MotionDataset
from motioncore.representation import decode_positions
from motioncore.skating import foot_skating_ratio

Method = Callable[[torch.Tensor, torch.Tensor, str, str], torch.Tensor]

FULL = {"per_content": 9, "examples_per_style": 7}
QUICK = {"per_content": 2, "examples_per_style": 1}
# The unseen-style protocol (models trained without the held-out styles): neutral content only, every neutral
# clip of each content in the full run (6 per content on test, 3 on val), targets the held-out (or the seen) styles.
UNSEEN_FULL = {"per_content": 6, "examples_per_style": 7}
HELD_OUT_STYLES = ("elderly", "exhausted", "feminine")  # strong, subtle and between: see
# docs/archive/RESULTS-notebook.md#first-ablation-val-split-the-defaults-of-that-time


@dataclass(frozen=True)
class Transfer:
    """One protocol item: indices are into the test split's records."""

    content_index: int
    style_index: int
    content: str
    source_style: str
    target_style: str


def protocol_clips(records: Sequence[ClipRecord], split: str = "test") -> list[int]:
    """Indices of the protocol's clips: Bandai-2, the given split (test; val for choosing settings), not mirrored."""
    return [i for i, r in enumerate(records) if r.dataset == "bandai2" and r.split == split and not r.mirrored]


def select_protocol(records: Sequence[ClipRecord], quick: bool = False, seed: int = 0,
                    per_content: int | None = None, examples_per_style: int | None = None,
                    examples_pool: int | None = None, split: str = "test", sources: Sequence[str] | None = None,
                    targets: Sequence[str] | None = None) -> list[Transfer]:
    """The seeded list of transfers (see the module doc); counts default to ``QUICK`` or ``FULL``.

    ``examples_pool``: draw each style's examples from a fixed seeded subset of this many of its
    clips (for methods that learn per example; default: all of the style's test originals).
    ``sources`` / ``targets``: only content clips of these styles, only transfers to these styles (default:
    all seven each; the unseen-style protocol takes neutral content to the held-out styles).
    """
    sizes = QUICK if quick else FULL
    per_content = sizes["per_content"] if per_content is None else per_content
    examples = sizes["examples_per_style"] if examples_per_style is None else examples_per_style
    rng = random.Random(seed)
    pool = protocol_clips(records, split)
    if not pool:
        raise ValueError(f"select_protocol: no non-mirrored Bandai-2 {split} clips in the cache")
    cells: dict[tuple[str, str], list[int]] = {}
    for i in pool:
        cells.setdefault((records[i].content, records[i].style), []).append(i)
    by_style: dict[str, list[int]] = {}
    for i in pool:
        by_style.setdefault(records[i].style, []).append(i)
    styles = [s for s in STYLES if s in by_style]
    for name, given in (("sources", sources), ("targets", targets)):
        unknown = sorted(set(given or ()) - set(styles))
        if unknown:
            raise ValueError(f"select_protocol: expected {name} among {', '.join(styles)}, got {', '.join(unknown)}")
    source_pool = [s for s in styles if sources is None or s in sources]
    target_pool = [s for s in styles if targets is None or s in targets]
    if examples_pool is not None:
        if examples_pool < 1:
            raise ValueError(f"select_protocol: expected examples_pool >= 1, got {examples_pool}")
        pool_rng = random.Random(seed + 1)
        by_style = {s: sorted(pool_rng.sample(v, min(examples_pool, len(v)))) for s, v in by_style.items()}
    contents = [c for c in BANDAI2_CONTENTS if any(k[0] == c for k in cells)]

    items = []
    for content in contents:
        source_styles = [s for s in source_pool if (content, s) in cells]
        if not source_styles:
            continue
        order: list[str] = []
        while len(order) < per_content:  # shuffled cycles: source styles as even as possible
            cycle = source_styles[:]
            rng.shuffle(cycle)
            order += cycle
        used: dict[str, list[int]] = {}
        for source in order[:per_content]:
            remaining = [i for i in cells[(content, source)] if i not in used.get(source, [])]
            if not remaining:  # more draws than clips in the cell: start over
                used[source], remaining = [], list(cells[(content, source)])
            ci = rng.choice(remaining)
            used.setdefault(source, []).append(ci)
            for target in target_pool:
                if target == source:
                    continue
                candidates = by_style[target]
                for si in rng.sample(candidates, min(examples, len(candidates))):
                    items.append(Transfer(ci, si, content, source, target))
    return items


def identity_transfer(content_feats: torch.Tensor, style_example: torch.Tensor, style_label: str,
                      content_label: str) -> torch.Tensor:
    """Baseline: the content motion unchanged."""
    return content_feats


def _check_output(name: str, out, content: torch.Tensor) -> torch.Tensor:
    if not torch.is_tensor(out) or out.shape != content.shape:
        shape = tuple(out.shape) if torch.is_tensor(out) else type(out).__name__
        raise ValueError(f"method {name!r}: expected output features {tuple(content.shape)}, got {shape}")
    if not torch.isfinite(out).all():
        raise ValueError(f"method {name!r}: output has non-finite values")
    return out.detach().float()


class _Scorer:
    """Metrics of a list of raw-feature motions with the two classifiers."""

    def __init__(self, content_clf: MotionClassifier, style_clf: MotionClassifier, fps: float):
        self.content_clf, self.style_clf, self.fps = content_clf, style_clf, fps

    @torch.no_grad()
    def score(self, raw: list[torch.Tensor], contents: list[str], styles: list[str]) -> dict:
        feats = run_batched(self.content_clf, [self.content_clf.standardize(x) for x in raw], "features")
        content_pred = self.content_clf.eval().head(feats).argmax(-1)  # = recognition_accuracy, one pass fewer
        style_feats = run_batched(self.style_clf, [self.style_clf.standardize(x) for x in raw], "features")
        style_pred = self.style_clf.eval().head(style_feats).argmax(-1)
        content_ok = content_pred == self.content_clf.label_index(contents)
        style_ok = style_pred == self.style_clf.label_index(styles)
        return {
            "features": feats,
            "style_features": style_feats,
            "cra": float(content_ok.float().mean()),
            "sra": float(style_ok.float().mean()),
            "by_style": by_target(styles, content_ok, style_ok, [self.style_clf.config.classes[int(i)] for i in style_pred]),
            "by_content": {c: float(content_ok[[i for i, x in enumerate(contents) if x == c]].float().mean())
                           for c in sorted(set(contents))},
            "content_read_as": _read_as(contents, [self.content_clf.config.classes[int(i)] for i in content_pred]),
            "skating": foot_skating_ratio([decode_positions(x.double()) for x in raw], self.fps),
        }


def _read_as(truth: Sequence[str], read: Sequence[str]) -> dict[str, dict[str, float]]:
    """For each true label, the share of its items read as each label, most often first."""
    out = {}
    for t in sorted(set(truth)):
        reads = [r for x, r in zip(truth, read) if x == t]
        out[t] = {r: reads.count(r) / len(reads) for r in sorted(set(reads), key=lambda r: -reads.count(r))}
    return out


def _misread(read_as: dict[str, float], truth: str) -> str:
    wrong = [(r, v) for r, v in read_as.items() if r != truth]
    return f" ({wrong[0][0]} {100 * wrong[0][1]:.0f})" if wrong else ""


def by_target(targets: Sequence[str], content_ok: torch.Tensor, style_ok: torch.Tensor,
              read_as: Sequence[str]) -> dict[str, dict]:
    """Per target style: ``{"n", "cra", "sra", "read_as": {style: share}}`` of the transfers to it (``content_ok``,
    ``style_ok``: ``(N,)`` bools; ``read_as``: the style classifier's reading of each output)."""
    shares = _read_as(targets, read_as)
    out = {}
    for s in sorted(set(targets)):
        idx = [i for i, t in enumerate(targets) if t == s]
        out[s] = {"n": len(idx), "cra": float(content_ok[idx].float().mean()), "sra": float(style_ok[idx].float().mean()),
                  "read_as": shares[s]}
    return out


def run_protocol(methods: dict[str, Method], data_dir: Path, quick: bool = True, seed: int = 0,
                 content_classifier: Path | None = None, style_classifier: Path | None = None,
                 per_content: int | None = None, examples_per_style: int | None = None, progress: bool = True,
                 examples_pool: int | None = None, split: str = "test", sources: Sequence[str] | None = None,
                 targets: Sequence[str] | None = None) -> list[dict]:
    """Run every method on the protocol's transfers; returns one row per method plus the real-data reference row first.

    Row keys: ``method``, ``transfers``, ``fmd``, ``fmd_style``, ``cra``, ``sra``, ``skating``,
    ``contact_agreement``, ``sec_per_transfer``, ``seconds`` (the method's transfer time in all).
    ``fmd_style``: for each target style S, the Fréchet distance between the style classifier's features of
    the outputs for S and of the real clips of style S, averaged over S (a style-aware FMD).
    ``split``: "test" to report; "val" to choose settings. ``sources``/``targets``: see :func:`select_protocol`.
    """
    data = MotionDataset(data_dir, split=split)
    content_clf = load_classifier(content_classifier or default_weights("content"))
    style_clf = load_classifier(style_classifier or default_weights("style"))
    fps = 20.0
    scorer = _Scorer(content_clf, style_clf, fps)
    items = select_protocol(data.records, quick, seed, per_content, examples_per_style, examples_pool, split,
                            sources, targets)

    real_idx = protocol_clips(data.records, split)
    real_raw = [data.clip(i, normalized=False) for i in real_idx]
    real_styles = [data.records[i].style for i in real_idx]
    real = scorer.score(real_raw, [data.records[i].content for i in real_idx], real_styles)
    rows = [{"method": f"real {split} clips (reference)", "transfers": len(real_idx), "fmd": None, "fmd_style": None,
             "cra": real["cra"],
             "sra": real["sra"], "skating": real["skating"], "contact_agreement": None, "sec_per_transfer": None, "seconds": None, "stray": None, "stray_share": None,
             "judge_sra": None, "judge_toward": None}]

    for name, method in methods.items():
        outputs, seconds = [], 0.0
        for it in tqdm(items, desc=name, disable=not progress, unit="transfer"):
            content, style = data.clip(it.content_index), data.clip(it.style_index)
            t0 = time.perf_counter()
            out = method(content.clone(), style.clone(), it.target_style, it.content)
            seconds += time.perf_counter() - t0
            outputs.append(data.denormalize(_check_output(name, out, content)))
        gen = scorer.score(outputs, [it.content for it in items], [it.target_style for it in items])
        rows.append({
            "method": name,
            "transfers": len(items),
            "fmd": frechet_distance(real["features"], gen["features"]),
            "fmd_style": style_fmd(real["style_features"], real_styles, gen["style_features"], [it.target_style for it in items]),
            "cra": gen["cra"],
            "sra": gen["sra"],
            "by_style": gen["by_style"],
            "by_content": gen["by_content"],
            "content_read_as": gen["content_read_as"],
            "skating": gen["skating"],
            "contact_agreement": foot_contact_agreement([data.clip(it.content_index, normalized=False) for it in items], outputs, fps),
            **stray_summary([data.clip(it.content_index, normalized=False) for it in items],
                            [data.clip(it.style_index, normalized=False) for it in items], outputs),
            **judge_scores(data_dir, [data.clip(it.content_index, normalized=False) for it in items], outputs,
                           [it.content for it in items], [it.target_style for it in items]),
            "sec_per_transfer": seconds / len(items),
            "seconds": seconds,
        })
    return rows


STRAY_LIMIT = 0.15  # metres: a limb's time-mean place this far off the content-to-example segment is a stray


def stray_summary(contents: Sequence[torch.Tensor], examples: Sequence[torch.Tensor],
                  outputs: Sequence[torch.Tensor]) -> dict:
    """``stray``: median over transfers of the worst limb's :func:`evaluation.metrics.limb_stray` (metres);
    ``stray_share``: the share of transfers with a limb strayed over :data:`STRAY_LIMIT`. Raw features."""
    worst = torch.stack([limb_stray(c, e, o).max() for c, e, o in zip(contents, examples, outputs)])
    return {"stray": float(worst.median()), "stray_share": float((worst > STRAY_LIMIT).float().mean())}


def style_fmd(real_feats: torch.Tensor, real_styles: Sequence[str], gen_feats: torch.Tensor,
              gen_styles: Sequence[str]) -> float | None:
    """Mean over target styles S of the Fréchet distance between the generated and the real features of S
    (``(N, F)`` and ``(M, F)`` with their style labels); styles with fewer than two outputs are skipped."""
    values = []
    for s in sorted(set(gen_styles)):
        g = gen_feats[[i for i, x in enumerate(gen_styles) if x == s]]
        r = real_feats[[i for i, x in enumerate(real_styles) if x == s]]
        if len(g) >= 2 and len(r) >= 2:
            values.append(frechet_distance(r, g))
    return sum(values) / len(values) if values else None


def format_table(rows: Sequence[dict]) -> str:
    """Markdown table of :func:`run_protocol` rows (accuracies and ratios in %)."""
    def num(v, fmt):
        return "–" if v is None else format(v, fmt)

    lines = [("| method | transfers | FMD ↓ | target-style FMD ↓ | CRA ↑ (%) | SRA ↑ (%) | foot skating (%) | "
             "contact agreement (%) | stray limb, median (cm) ↓ | strays > 15 cm (%) ↓ | judge SRA ↑ (%) | "
             "judge: towards the style ↑ (%) | s / transfer |"),
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        pct = {k: None if r.get(k) is None else 100 * r[k]
               for k in ("cra", "sra", "skating", "contact_agreement", "stray", "stray_share", "judge_sra", "judge_toward")}
        lines.append(f"| {r['method']} | {r['transfers']} | {num(r.get('fmd'), '.2f')} | {num(r.get('fmd_style'), '.2f')} | "
                     f"{num(pct['cra'], '.1f')} | "
                     f"{num(pct['sra'], '.1f')} | {num(pct['skating'], '.1f')} | {num(pct['contact_agreement'], '.1f')} | "
                     f"{num(pct['stray'], '.1f')} | {num(pct['stray_share'], '.0f')} | "
                     f"{num(pct['judge_sra'], '.1f')} | {num(pct['judge_toward'], '.1f')} | "
                     f"{num(r.get('sec_per_transfer'), '.4f')} |")
    notes = [f"- {r['method']}, by target style (CRA / SRA %; most read as; judge SRA / towards %): "
             + "; ".join(f"{s} {100 * v['cra']:.0f} / {100 * v['sra']:.0f} ({next(iter(v['read_as']))}; "
                         + ("–" if s not in r.get("judge_by_style", {}) else
                            f"{100 * r['judge_by_style'][s][0]:.0f} / {100 * r['judge_by_style'][s][1]:.0f}") + ")"
                         for s, v in r["by_style"].items())
             for r in rows if r.get("by_style")]
    notes += [f"- {r['method']}, CRA by content (%; the wrong reading most often): "
              + "; ".join(f"{c} {100 * v:.0f}" + _misread(r.get("content_read_as", {}).get(c, {}), c)
                          for c, v in r["by_content"].items())
              for r in rows if r.get("by_content")]
    return "\n".join(lines + ([""] + notes if notes else []))
