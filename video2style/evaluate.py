"""``video2style evaluate``: the Bandai-2 protocol (:mod:`transfer.evaluation`) over the project's methods.

Methods (names as on the command line):

- ``identity``: the content clip unchanged (baseline);
- ``stgcn``: Park et al.'s stylizer, style code from the style example through E, then what
  ``apply --method stgcn`` does (rotations fitted to its position channels, foot cleanup) and
  encoding again; ``stgcn-raw``: its output features as they come;
- ``ours``: Hu et al.'s on-the-fly method as ``learn`` + ``apply`` run it: one style learned per
  distinct style example (cached for the run; learning time is reported apart), content
  neutralised when the motion encoder reads it as styled, K = 300, foot cleanup;
- ablations: ``ours-no-ls`` (lambda_s = 0), ``ours-no-pp`` (no prior preservation: Hu et al.'s loss
  exactly), ``ours-no-pair`` (fine-tuned from the example itself,
  no neutral pair), ``ours-k150`` and ``ours-k600`` (other K).

Learning costs a fixed budget per example (30 s quick, 60 s full by default), so style examples
are drawn from a pool of clips per style (``examples_pool``: 1 quick, 3 full): 7 or 21 learned
styles per variant of ours. Each content clip is neutralised once and reused for its six targets.
"""
from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import torch

from motioncore.cleanup import cleanup_feet
from motioncore.ik_fit import decode_via_positions
from motioncore.representation import decode, encode

ABLATIONS = {
    "ours": {},
    "ours-no-ls": {"lambda_s": 0.0},
    "ours-no-pp": {"lambda_p": 0.0},
    "ours-no-pair": {"pair_generation": False},
    "ours-k150": {"transfer_step": 150, "transfer_steps": 3},
    "ours-k600": {"transfer_step": 600, "transfer_steps": 12},
}
METHODS = ("identity", "stgcn", "stgcn-raw", *ABLATIONS)


def cleaned(features_fn, mean: torch.Tensor, std: torch.Tensor, from_positions: bool = False):
    """Wrap a method returning normalised features so its output goes through decoding (from the rotation
    channels, or from the positions as ``apply --method stgcn`` does), foot cleanup and encoding again."""
    def transfer(content, style, style_label, content_label):
        out = features_fn(content, style, style_label, content_label)
        content_m = decode(content * std + mean)
        out_m = decode_via_positions(out * std + mean, content_m.fps) if from_positions else decode(out * std + mean)
        return (encode(cleanup_feet(out_m, reference=content_m)) - mean) / std

    return transfer


class OnTheFly:
    """Our method as a protocol method: learns (once) a style per style example, then applies it."""

    def __init__(self, models, content_data, config, seed: int = 0, progress=None):
        self.m, self.data, self.config, self.seed = models, content_data, config, seed
        self.styles: dict[str, torch.nn.Module] = {}
        self.neutral: dict[str, torch.Tensor] = {}
        self.learn_seconds: list[float] = []
        self.say = progress or (lambda s: None)

    def _model(self, style: torch.Tensor, style_label: str):
        from transfer.apply import classify_caption
        from transfer.style import learn_style, style_model

        key = hashlib.sha1(style.numpy().tobytes()).hexdigest() + style_label
        if key not in self.styles:
            t0 = time.time()
            content, _, _ = classify_caption(self.m.motion_encoder, self.m.text_encoder, style)
            learned, _ = learn_style(self.m.prior, self.m.motion_encoder, self.m.text_encoder, self.data, style,
                                     style_label, content, self.config)
            self.styles[key] = style_model(self.m.prior, learned)
            self.learn_seconds.append(time.time() - t0)
            self.say(f"learned {style_label!r} from a {content} example in {self.learn_seconds[-1]:.0f} s")
        return self.styles[key]

    def __call__(self, content, style, style_label, content_label):
        from transfer.apply import (
            apply_style_features,
            classify_caption,
            neutralize_features,
        )
        from transfer.captions import content_caption

        model = self._model(style, style_label)
        key = hashlib.sha1(content.numpy().tobytes()).hexdigest()
        if key not in self.neutral:  # each content clip goes to six styles: neutralise it once
            detected, source_style, _ = classify_caption(self.m.motion_encoder, self.m.text_encoder, content)
            self.neutral[key] = content if source_style == "normal" else neutralize_features(
                self.m.prior, content, self.m.text_encoder.encode([content_caption(detected)]), self.config, self.seed)
        return apply_style_features(model, self.m.prior, self.neutral[key], self.config, self.config.transfer_step, self.seed)


def build_methods(names: list[str], data_dir: Path, learn_seconds: float, seed: int = 0, say=print,
                  stgcn_weights: Path | None = None) -> tuple[dict, dict]:
    """``({name: method}, {name: OnTheFly})`` for the requested method names (``stgcn_weights``: default the shipped ones)."""
    from transfer.dataset import MotionDataset
    from transfer.evaluation import identity_transfer
    from transfer.style import StyleConfig

    unknown = [n for n in names if n not in METHODS]
    if unknown:
        raise ValueError(f"evaluate: unknown method(s) {', '.join(unknown)}; expected some of {', '.join(METHODS)}")
    test = MotionDataset(data_dir, "test")
    methods, learners = {}, {}
    for name in names:
        if name == "identity":
            methods[name] = identity_transfer
        elif name in ("stgcn", "stgcn-raw"):
            from transfer.park.infer import park_method
            from video2style.stgcn import load_stylizer

            method = park_method(load_stylizer(stgcn_weights), seed)
            methods[name] = method if name == "stgcn-raw" else cleaned(method, test.mean, test.std, from_positions=True)
        else:
            from video2style.pipeline import load_models

            m = load_models()
            config = replace(StyleConfig(), max_seconds=learn_seconds, seed=seed, **ABLATIONS[name])
            learner = OnTheFly(m, MotionDataset(data_dir, "train"), config, seed, progress=lambda s, n=name: say(f"  {n}: {s}"))
            learners[name] = learner
            methods[name] = cleaned(learner, test.mean, test.std)
    return methods, learners


def evaluate(data_dir: Path, out_dir: Path, quick: bool = True, methods: list[str] | None = None, seed: int = 0,
             learn_seconds: float | None = None, examples_pool: int | None = None, say=print,
             stgcn_weights: Path | None = None) -> Iterator[str]:
    """Run the protocol; writes ``out_dir/table.md`` and ``rows.json``; yields the report lines."""
    from transfer.evaluation import format_table, run_protocol

    if not (Path(data_dir) / "features.safetensors").is_file():
        raise FileNotFoundError(f"{data_dir}: no dataset cache (build it with video2style dataset)")
    names = list(methods or ["identity", "stgcn", "ours"])
    learn_seconds = learn_seconds or (30.0 if quick else 60.0)
    if examples_pool is None and any(n.startswith("ours") for n in names):
        examples_pool = 1 if quick else 3
    t0 = time.time()
    fns, learners = build_methods(names, data_dir, learn_seconds, seed, say, stgcn_weights)
    rows = run_protocol(fns, Path(data_dir), quick=quick, seed=seed, examples_pool=examples_pool)
    for row in rows:
        learner = learners.get(row["method"])
        if learner is not None and learner.learn_seconds:
            row["styles_learned"] = len(learner.learn_seconds)
            row["learn_seconds_mean"] = sum(learner.learn_seconds) / len(learner.learn_seconds)
    table = format_table(rows)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    learned = [f"- {r['method']}: {r['styles_learned']} styles learned, {r['learn_seconds_mean']:.0f} s each "
               "(included in s / transfer)" for r in rows if "styles_learned" in r]
    header = (f"protocol: {'quick' if quick else 'full'}, seed {seed}, style examples from "
              f"{examples_pool or 'all'} clip(s) per style, learning budget {learn_seconds:g} s per example; "
              f"{time.time() - t0:.0f} s in all")
    (out_dir / "table.md").write_text("\n".join([header, "", table, "", *learned]) + "\n")
    (out_dir / "rows.json").write_text(json.dumps(rows, indent=1))
    yield header
    yield table
    yield from learned
    yield f"wrote {out_dir / 'table.md'} and {out_dir / 'rows.json'}"
