"""``video2style evaluate``: the Bandai-2 protocol (:mod:`evaluation.protocol`) over the project's methods.

Methods (names as on the command line):

- ``identity``: the content clip unchanged (baseline);
- ``park``: Park et al.'s stylizer, style code from the style example through E, then what
  ``apply --method park`` does (rotations fitted to its position channels, foot cleanup) and
  encoding again; ``park-raw``: its output features as they come;
- ``ours``: Hu et al.'s on-the-fly method as ``learn`` + ``apply`` run it: one style learned per
  distinct style example (cached for the run and shared by the variants that learn the same way),
  content neutralised when the motion encoder reads it as styled, foot cleanup;
- variants of ours (:data:`VARIANTS`): ablations of the learning loss and of how the style is applied.

Older names (:data:`video2style.methods.ALIASES`: ``stgcn``, variants that now equal another) run, and name
their rows, as the methods they stand for.

Learning has a fixed budget of iterations per example (:class:`transfer.style_config.LearnConfig`), so
style examples are drawn from a pool of clips per style (``examples_pool``: 1 quick, 3 full): 7 or
21 learned styles per learning setting. Each content clip is neutralised once and reused.

``strengths``: each variant of ours is also run at these ``--strength`` values (rows ``name @s``),
and ``tradeoff.png`` plots CRA against SRA, one curve per variant.
"""
from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Iterator
from dataclasses import asdict, replace
from pathlib import Path

import torch

from motioncore.files import atomic_write_text
from motioncore.ik_fit import decode_via_positions
from motioncore.representation import decode, encode
from video2style.methods import METHODS, VARIANTS, method_names

HU_ET_AL = {"cra": 0.9341, "sra": 0.6011, "fmd": 2.33}  # their Table 1 row, with their classifiers


def cleaned(features_fn, data, decoder_for=lambda content, example: decode):
    """Wrap a method returning normalised features so its output goes through decoding (``decoder_for(content
    motion, style example's raw features)`` gives the decode function: from the rotation channels by default, from
    the positions as ``apply --method park`` does, or as :func:`transfer.apply.decoder` says for a style, its
    stray-limb guard included), apply's last stage (:func:`transfer.spans.clean_feet` at ``--feet auto``: spikes
    drawn out, the feet cleaned) and encoding again; normalised as the protocol's ``data``
    (:class:`mlcore.dataset.MotionDataset`) is."""
    from transfer.spans import clean_feet, example_feet

    def transfer(content_feats, style_example, style_label, content_label):
        out = features_fn(content_feats, style_example, style_label, content_label)
        content_m = decode(data.denormalize(content_feats))
        example = data.denormalize(style_example)
        out_m = decoder_for(content_m, example)(data.denormalize(out), content_m.fps)
        result, _ = clean_feet(out_m, content_m, "auto", None, example_feet(example), slice(0, content_m.num_frames))
        return data.standardize(encode(result))

    return transfer


def _key(*parts) -> str:
    h = hashlib.sha1()
    for p in parts:
        h.update(p.numpy().tobytes() if torch.is_tensor(p) else json.dumps(p, sort_keys=True).encode())
    return h.hexdigest()


ADDED_OFF = ("lambda_stat_dir", "pair_between")  # learning fields added later: off (0 / False, as learning ran before
# them), a style cache's key leaves them out, so a cache from before serves


class OnTheFly:
    """Our method as a protocol method: learns (once) a style per style example, then applies it.

    ``learned``: how it learns (:class:`transfer.style_config.LearnConfig`); ``config``: how it applies
    (:class:`transfer.style_config.ApplyConfig`, default: today's). ``shared``: a dict shared between instances, so
    variants that learn the same way (they differ only in ``config`` or strength) reuse each other's styles and
    neutralised contents.
    """

    def __init__(self, bundle, content_data, learned, config=None, seed: int = 0, progress=None,
                 strength: float | None = None, shared: dict | None = None, store: Path | None = None,
                 words: str | None = None):
        from transfer.style_config import ApplyConfig

        self.m, self.data, self.learned, self.seed, self.strength = bundle, content_data, learned, seed, strength
        self.config = config or ApplyConfig()
        self.words = words  # the style words learning is given (None: the style's name)
        self.store = store  # a folder keeping learned styles between runs (keyed by example and learning config)
        self.shared = shared if shared is not None else {}
        self.learn_seconds: list[float] = []
        self.iterations: list[int] = []
        self._seen: set[str] = set()  # styles this variant used (for its row's learning numbers)
        self.progress = progress or (lambda s: None)

    def _model(self, style_example: torch.Tensor, style_label: str):
        from transfer.apply import read_motion
        from transfer.learn import learn_style
        from transfer.style_config import OLD_NAMES
        from transfer.style_file import Style, style_model

        # keyed by the names the step fields had before (OLD_NAMES), so a --style-cache folder from before still serves
        before = {new: old for old, new in OLD_NAMES.items()}
        learn_config = {before.get(k, k): v for k, v in asdict(self.learned).items()
                        if k != "max_seconds" and not (k in ADDED_OFF and v == 0)}  # keys of a cache from before
        words = self.words or style_label
        key = "style" + _key(style_example, words, learn_config, str(getattr(self.m, "prior_path", "")))
        stored = None if self.store is None else Path(self.store) / f"{key}.v2s"
        if key not in self.shared and stored is not None and stored.is_file():
            learned = Style.load(stored)
            self.shared[key] = (style_model(self.m.prior, learned), learned.meta["seconds"], learned.meta["iterations"],
                                learned.gain)
            self._keep_posture(style_example, learned)
        if key not in self.shared:
            t0 = time.time()
            content_label = read_motion(self.m.motion_encoder, self.m.text_encoder, style_example).content
            learned, _ = learn_style(self.m, self.data, style_example, words, content_label, self.learned,
                                     apply=self.config)
            if stored is not None:
                learned.save(stored)
            self.shared[key] = (style_model(self.m.prior, learned), time.time() - t0, learned.meta["iterations"],
                                learned.gain)
            self._keep_posture(style_example, learned)
            self.progress(f"learned {style_label!r} from a {content_label} example: {learned.meta['iterations']} iterations, "
                     f"{self.shared[key][1]:.0f} s")
        model, seconds, iterations, gain = self.shared[key]
        if key not in self._seen:
            self._seen.add(key)
            self.learn_seconds.append(seconds)
            self.iterations.append(iterations)
        return model, gain

    def _neutral(self, content: torch.Tensor) -> torch.Tensor:
        from transfer.apply import neutral_caption, neutralize_features

        pair_config = {"neutralize_step": self.config.neutralize_step,
                       **{k: getattr(self.learned, k) for k in ("pair_noise_step", "pair_ddim_steps", "guidance")}}
        key = "neutral" + _key(content, pair_config, self.seed)
        if key not in self.shared:  # each content clip goes to six styles: neutralise it once
            _, text = neutral_caption(self.m.motion_encoder, self.m.text_encoder, content)
            skip = text is None or self.config.neutralize_step == 0
            self.shared[key] = content if skip else neutralize_features(self.m, content, text, self.learned, self.config, self.seed)
        return self.shared[key]

    def __call__(self, content_feats, style_example, style_label, content_label):
        from transfer.apply import apply_style_features

        model, gain = self._model(style_example, style_label)
        return apply_style_features(self.m, model, self._neutral(content_feats), self.learned, self.config,
                                    self.strength, self.seed, posture_shift=self._posture(style_example),
                                    example=self.data.denormalize(style_example), gain=gain)

    def _keep_posture(self, style_example: torch.Tensor, learned) -> None:
        """A learned style's posture change (drawn while learning): :meth:`_posture` need not draw the pair again."""
        if learned.posture_shift is not None:
            self.shared.setdefault(self._posture_key(style_example), learned.posture_shift)

    def _posture_key(self, style_example: torch.Tensor) -> str:
        parts = (style_example, self.learned.seed, self.learned.pair_noise_step, self.learned.pair_ddim_steps)
        return "posture" + _key(*parts, *(("between",) if self.learned.pair_between else ()))

    def _posture(self, style_example: torch.Tensor) -> torch.Tensor | None:
        """The example's time-mean change against its neutral pair (drawn as learning draws it), for ``posture``."""
        if self.config.posture <= 0:
            return None
        key = self._posture_key(style_example)
        if key not in self.shared:  # a style from a cache of before: its pair drawn again
            from transfer.learn import neutral_pair
            from transfer.style_losses import posture_shift

            self.shared[key] = posture_shift(style_example, neutral_pair(self.m, style_example, self.learned, dataset=self.data))
        return self.shared[key]


def build_methods(names: list[str], data_dir: Path, seed: int = 0, progress=print, park_weights: Path | None = None,
                  strengths: list[float] | None = None, iterations: int | None = None,
                  style_cache: Path | None = None, models_dir: Path | None = None, exclude_styles: tuple[str, ...] = (),
                  words: str | None = None) -> tuple[dict, dict]:
    """``({row name: method}, {row name: OnTheFly})`` for the requested method names (older names: as
    :func:`video2style.methods.method_names` says; ``park_weights``: default
    the shipped ones). Variants of ours get one row per strength in ``strengths`` (default: their own setting).
    ``models_dir``: the prior and motion encoder from this folder instead of the shipped ones, with the content
    clips for learning drawn without ``exclude_styles`` (the unseen-style protocol); ``words``: the style words
    every style is learned under (default: its name)."""
    from evaluation.protocol import identity_transfer
    from mlcore.dataset import MotionDataset
    from transfer.style_config import split_config

    names = method_names(names)
    unknown = [n for n in names if n not in METHODS]
    if unknown:
        raise ValueError(f"evaluate: unknown method(s) {', '.join(unknown)}; expected some of {', '.join(METHODS)}")
    test = MotionDataset(data_dir, "test")
    methods, learners, shared = {}, {}, {}
    train = None
    for name in names:
        if name == "identity":
            methods[name] = identity_transfer
        elif name in ("park", "park-raw"):
            from park.infer import park_method
            from video2style.park_apply import park_model

            method = park_method(park_model(park_weights), seed)
            methods[name] = method if name == "park-raw" else cleaned(method, test,
                                                                       lambda content, example: decode_via_positions)
        else:
            from transfer.apply import decoder
            from transfer.bundle import MethodBundle, load_models

            m = load_models() if models_dir is None else MethodBundle.from_pretrained(Path(models_dir))
            train = train or MotionDataset(data_dir, "train", exclude_styles=exclude_styles)
            learned, config = split_config({"seed": seed, **VARIANTS[name]})
            if iterations is not None:
                learned = replace(learned, iterations=iterations)
            for strength in strengths or [None]:
                row = name if strength is None else f"{name} @{strength:g}"
                learner = OnTheFly(m, train, learned, config, seed, progress=lambda s, n=name: progress(f"  {n}: {s}"),
                                   strength=strength, shared=shared, store=style_cache, words=words)
                learners[row] = learner
                methods[row] = cleaned(learner, test, lambda content, example, c=config: decoder(c, reference=content,
                                                                                                 example=example))
    return methods, learners


def unseen_models_dir() -> Path:
    """The development weights of the unseen-style protocol: a prior and motion encoder trained with the shipped
    recipe but without the held-out styles (:data:`evaluation.protocol.HELD_OUT_STYLES`); not in the wheel."""
    import evaluation

    return Path(evaluation.__file__).parent / "weights" / "unseen"


def evaluate(data_dir: Path, out_dir: Path, quick: bool = True, methods: list[str] | None = None, seed: int = 0,
             examples_pool: int | None = None, progress=print, park_weights: Path | None = None,
             split: str = "test", strengths: list[float] | None = None, iterations: int | None = None,
             style_cache: Path | None = None, unseen: bool = False, unseen_models: Path | None = None,
             words: str | None = None, groups: tuple[str, ...] | list[str] = ("held-out", "seen")) -> Iterator[str]:
    """Run the protocol; writes ``out_dir/table.md``, ``rows.json`` and ``tradeoff.png``; yields the report lines.

    ``unseen``: the unseen-style protocol: our methods use the models in ``unseen_models`` (default
    :func:`unseen_models_dir`), trained without the held-out styles; neutral content clips of every content
    go to the held-out styles (rows marked "[held-out]") and, from the same models, to the other styles
    ("[seen]"); ``groups``: only these of the two. ``words``: learn every style under these words instead of its name.
    """
    from evaluation.protocol import (
        HELD_OUT_STYLES,
        UNSEEN_FULL,
        format_table,
        run_protocol,
    )
    from mlcore.captions import NEUTRAL_STYLE, STYLES
    from transfer.style_config import LearnConfig

    if not (Path(data_dir) / "features.safetensors").is_file():
        raise FileNotFoundError(f"{data_dir}: no dataset cache (build it with video2style dataset)")
    if split not in ("test", "val"):
        raise ValueError(f"evaluate: expected split 'test' or 'val', got {split!r}")
    names = method_names(methods or ["identity", "park", "ours"])
    if examples_pool is None and any(n.startswith("ours") for n in names):
        examples_pool = 1 if quick else 3
    t0 = time.time()
    models_dir, excluded = None, ()
    if unseen:
        models_dir, excluded = Path(unseen_models or unseen_models_dir()), HELD_OUT_STYLES
        if any(n.startswith("ours") for n in names):
            from transfer.bundle import ENCODER_FILE, PRIOR_FILE

            for f in (PRIOR_FILE, ENCODER_FILE):
                if not (models_dir / f).is_file():
                    raise FileNotFoundError(f"{models_dir / f}: no held-out model (train it with train-prior / "
                                            f"train-encoder --exclude-styles {' '.join(HELD_OUT_STYLES)})")
    fns, learners = build_methods(names, data_dir, seed, progress, park_weights, strengths, iterations, style_cache,
                                  models_dir, excluded, words)
    if unseen:
        per_content = None if quick else UNSEEN_FULL["per_content"] // (2 if split == "val" else 1)
        only, groups = groups, {"held-out": HELD_OUT_STYLES,
                  "seen": tuple(s for s in STYLES if s not in HELD_OUT_STYLES and s != NEUTRAL_STYLE)}
        rows = []
        unknown = sorted(set(only) - set(groups))
        if unknown or not only:
            raise ValueError(f"evaluate: expected groups among {', '.join(groups)}, got {', '.join(unknown) or 'none'}")
        for group, targets in ((g, t) for g, t in groups.items() if g in only):
            part = run_protocol(fns, Path(data_dir), quick=quick, seed=seed, examples_pool=examples_pool, split=split,
                                per_content=per_content, sources=(NEUTRAL_STYLE,), targets=targets)
            for r in part[1:]:
                r.update(group=group, base_method=r["method"], method=f"{r['method']} [{group}]")
            rows += part if not rows else part[1:]
    else:
        rows = run_protocol(fns, Path(data_dir), quick=quick, seed=seed, examples_pool=examples_pool, split=split)
    for row in rows:
        learner = learners.get(row.get("base_method", row["method"]))
        if learner is not None and learner.learn_seconds:
            row["styles_learned"] = len(learner.learn_seconds)
            row["learn_seconds_mean"] = sum(learner.learn_seconds) / len(learner.learn_seconds)
            row["iterations_min"] = min(learner.iterations)
            row["strength"] = learner.strength
    table = format_table(rows)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    learned = [f"- {r['method']}: {r['styles_learned']} styles, {r['learn_seconds_mean']:.0f} s each to learn "
               f"(at least {r['iterations_min']} iterations)" for r in rows if "styles_learned" in r]
    kind = "quick" if quick else "full"
    if unseen:
        kind += (f" unseen-style (models of {models_dir}, trained without {', '.join(HELD_OUT_STYLES)}; neutral content"
                 + (f"; styles learned as {words!r}" if words else "") + ")")
    elif words:
        kind += f" (styles learned as {words!r})"
    header = (f"protocol: {kind} on the {split} split, seed {seed}, style examples from "
              f"{examples_pool or 'all'} clip(s) per style, {iterations or LearnConfig.iterations} learning iterations "
              f"per example; {time.time() - t0:.0f} s in all")
    atomic_write_text(out_dir / "table.md", "\n".join([header, "", table, "", *learned]) + "\n")
    atomic_write_text(out_dir / "rows.json", json.dumps(rows, indent=1))
    plot = plot_tradeoff(rows, out_dir / "tradeoff.png", title=header.split(";")[0])
    yield header
    yield table
    yield from learned
    yield f"wrote {out_dir / 'table.md'}, {out_dir / 'rows.json'} and {plot}"


def plot_tradeoff(rows: list[dict], path: Path, title: str = "") -> Path:
    """CRA against SRA: one curve per variant of ours over its strengths, a point per other method and
    Hu et al.'s published point. Written atomically as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves: dict[str, list[tuple[float, float, float]]] = {}
    points = []
    for r in rows:
        if r["method"].startswith("real"):
            continue
        name, group = r.get("base_method", r["method"]), r.get("group")
        base, _, s = name.partition(" @")
        if group:
            base = f"{base} [{group}]"
        if s:
            curves.setdefault(base, []).append((float(s), 100 * r["sra"], 100 * r["cra"]))
        else:
            points.append((r["method"], 100 * r["sra"], 100 * r["cra"]))
    fig, ax = plt.subplots(figsize=(7, 5.5), dpi=110)
    for name, pts in curves.items():
        pts.sort()
        line, = ax.plot([p[1] for p in pts], [p[2] for p in pts], "o-", label=name)
        for s, x, y in pts:
            ax.annotate(f"{s:g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7, color=line.get_color())
    for name, x, y in points:
        ax.plot([x], [y], "s", label=name)
    ax.plot([100 * HU_ET_AL["sra"]], [100 * HU_ET_AL["cra"]], "*", ms=14, color="k", label="Hu et al. (published)")
    ax.axhline(93, color="grey", lw=0.6, ls="--")
    ax.axvline(65, color="grey", lw=0.6, ls="--")
    ax.set_xlabel("SRA: style recognition accuracy (%) →")
    ax.set_ylabel("CRA: content recognition accuracy (%) →")
    ax.set_title(title, fontsize=8)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    from motioncore.files import atomic_output

    path = Path(path)
    try:
        with atomic_output(path, ".png") as tmp:
            fig.savefig(tmp)
    finally:
        plt.close(fig)
    return path


def evaluate_dev_styles(dev_archive: Path, seen_archive: Path, out_dir: Path, strength: float = 0.5, seed: int = 0,
                        calibrate: bool = False, style_cache: Path | None = None, progress=print) -> Iterator[str]:
    """The second unseen-style protocol (:mod:`evaluation.dev_styles`): each of the five dev styles learned from
    its walk as ``learn`` learns (the shipped models, content from the dataset cache or the bank), applied as
    ``apply`` applies (:meth:`video2style.loaded_style.LoadedStyle.stylize`) at ``strength`` to the neutral clip of each action;
    writes ``out_dir/dev_styles.md`` and ``dev_styles.json``; yields the report lines. ``calibrate``: each style
    calibrated (:mod:`transfer.amount`; off: gain 1, the default). ``style_cache``: a folder keeping the learned styles between runs."""
    from evaluation.dev_styles import (
        fit_judges,
        format_dev_table,
        read_archive,
        run_dev_protocol,
    )
    from transfer.apply import read_motion
    from transfer.bundle import load_models
    from transfer.learn import learn_style
    from transfer.style_config import LearnConfig
    from transfer.style_file import Style
    from video2style.loaded_style import LoadedStyle
    from video2style.options import ApplyOptions
    from video2style.pipeline import content_source

    t0 = time.time()
    clips = read_archive(dev_archive) + read_archive(seen_archive)
    judges = fit_judges(clips)
    yield (f"judges fitted on {len(clips) - 5} real Bandai-1 clips: style {100 * judges.loo_style:.1f} %, action "
           f"{100 * judges.loo_action:.1f} % leave-one-out")
    m, data = load_models(), content_source(progress)
    learned = LearnConfig(seed=seed, calibrate=calibrate)
    request = ApplyOptions(strength=strength, seed=seed)
    styles: dict[str, LoadedStyle] = {}

    def transfer(style, example, action, content):
        if style not in styles:
            key = "dev" + _key(example, style, asdict(learned))
            path = None if style_cache is None else Path(style_cache) / f"{key}.v2s"
            if path is not None and path.is_file():
                st = Style.load(path)
            else:
                x = m.normalize(example)
                st, _ = learn_style(m, data, x, style, read_motion(m.motion_encoder, m.text_encoder, x).content, learned)
                st.example = example.clone()
                if path is not None:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    st.save(path)
            styles[style] = LoadedStyle.from_style(st, m)
            progress(f"  learned {style!r}: gain {st.gain:.2f}")
        return encode(styles[style].stylize(decode(content), request)[0])

    result = run_dev_protocol(transfer, clips, judges, progress=lambda s: progress(f"  {s}"))
    identity = run_dev_protocol(lambda s, e, a, c: c, clips, judges)
    title = (f"dev styles at --strength {strength:g}{', calibrated' if calibrate else ''}, seed {seed}; "
             f"{time.time() - t0:.0f} s")
    table = format_dev_table(result, identity)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out_dir / "dev_styles.md", f"{title}\n\n{table}\n")
    atomic_write_text(out_dir / "dev_styles.json", json.dumps(result, indent=1))
    yield title
    yield table
