"""Quality of the shipped prior and motion encoder on the Bandai-2 test split (issue 4's evidence).

    python benchmarks/eval_prior.py [--data cache/dataset] [--previews prior_previews/] [--threads 2] [--prior W] [--encoder W]
        [--steps 50] [--guidance 2.0] [--contact-rate 0.02] [--contact-iterations 2] [--no-derive-positions]

Samples are drawn with the project's text-to-motion settings (``transfer.sampling.TextToMotion``) unless the options
say otherwise (``--contact-rate 0``: without the planted-feet guide).

Prints retrieval R@1/R@3 (motion -> text over content captions and over content x style captions,
text -> motion in galleries of 32), then samples one clip per content x style caption and prints
the Fréchet distance to the real test originals on the motion encoder's features and on the
evaluation content classifier's features, the foot-skating ratio of samples and of real clips (placed by the
position channels, and ``_rotations``: by the rotation channels, as the pipeline decodes),
and seconds per sample. ``--previews`` writes one mp4 per content with its seven styles side by side.
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

import torch

from evaluation.metrics import frechet_distance
from mlcore.captions import BANDAI2_CONTENTS, STYLES, caption, content_caption
from mlcore.dataset import MotionDataset
from motioncore.render import Panel, render_video
from motioncore.representation import decode, decode_positions
from motioncore.skating import foot_skating_ratio
from motioncore.skeleton import CANONICAL
from transfer.sampling import TEXT_TO_MOTION, TextToMotion

MAX_FRAMES = 160


def _embed(encoder, clips: list[torch.Tensor]) -> torch.Tensor:
    out = []
    with torch.no_grad():
        for x in clips:
            out.append(encoder(x[None, :MAX_FRAMES])[0])
    return torch.stack(out)


def _recall(ranks: torch.Tensor, k: int) -> float:
    return float((ranks < k).float().mean())


def retrieval(encoder, text_encoder, data: MotionDataset, seed: int = 0, gallery: int = 32) -> dict:
    idx = [i for i, r in enumerate(data.records) if r.dataset == "bandai2" and not r.mirrored]
    z = _embed(encoder, [data.clip(i) for i in idx])
    contents = [data.records[i].content for i in idx]
    styles = [data.records[i].style for i in idx]
    out = {"clips": len(idx)}
    content_emb = text_encoder.encode([content_caption(c) for c in BANDAI2_CONTENTS])
    truth = torch.tensor([BANDAI2_CONTENTS.index(c) for c in contents])
    sims = z @ content_emb.T
    ranks = (sims > sims.gather(1, truth[:, None])).sum(1)
    out["m2t_content_R@1"], out["m2t_content_R@3"] = _recall(ranks, 1), _recall(ranks, 3)
    pairs = [(c, s) for c in BANDAI2_CONTENTS for s in STYLES]
    full_emb = text_encoder.encode([caption(c, s) for c, s in pairs])
    truth = torch.tensor([pairs.index((c, s)) for c, s in zip(contents, styles)])
    sims = z @ full_emb.T
    ranks = (sims > sims.gather(1, truth[:, None])).sum(1)
    out["m2t_full_R@1"], out["m2t_full_R@3"] = _recall(ranks, 1), _recall(ranks, 3)
    # text -> motion: the query caption's clip among 31 clips of other contents
    gen = torch.Generator().manual_seed(seed)
    q_emb = text_encoder.encode([content_caption(c) for c in contents])
    ranks = []
    for a in range(len(idx)):
        others = [b for b in range(len(idx)) if contents[b] != contents[a]]
        pick = torch.randperm(len(others), generator=gen)[: gallery - 1].tolist()
        g = torch.stack([z[a]] + [z[others[p]] for p in pick])
        s = g @ q_emb[a]
        ranks.append(int((s > s[0]).sum()))
    ranks = torch.tensor(ranks)
    out["t2m_content_R@1"], out["t2m_content_R@3"] = _recall(ranks, 1), _recall(ranks, 3)
    return out


def sample_quality(bundle, data: MotionDataset, out_dir: Path | None, length: int = 80,
                   settings: TextToMotion = TEXT_TO_MOTION, seed: int = 0, classifier=None) -> dict:
    """Samples ``(length, D)`` of the prior of ``bundle`` (:class:`transfer.bundle.MethodBundle`, drawn as ``settings``
    say) for every content x style caption, against ``data``'s clips; ``classifier`` (the evaluation's content
    classifier) adds an FD on its features."""
    encoder, text_encoder, denormalize = bundle.motion_encoder, bundle.text_encoder, bundle.denormalize
    gen = torch.Generator().manual_seed(seed)
    pairs = [(c, s) for c in BANDAI2_CONTENTS for s in STYLES]
    t0 = time.time()
    samples = []
    for c, s in pairs:
        x = bundle.text_to_motion(text_encoder.encode([caption(c, s)]), length, gen, settings)[0]
        samples.append(x)
    per_sample = (time.time() - t0) / len(pairs)
    real_idx = [i for i, r in enumerate(data.records) if r.dataset == "bandai2" and not r.mirrored]
    real = [data.clip(i)[:length] for i in real_idx]
    fd = frechet_distance(_embed(encoder, samples).numpy(), _embed(encoder, real).numpy())
    pos_samples = [decode_positions(denormalize(x)) for x in samples]
    pos_real = [decode_positions(denormalize(x)) for x in real]
    out = {"samples": len(samples), "seconds_per_sample": per_sample, **asdict(settings),
           "fd_encoder_features": fd, "skating_samples": foot_skating_ratio(pos_samples),
           "skating_real": foot_skating_ratio(pos_real),
           "skating_samples_rotations": foot_skating_ratio([decode(denormalize(x)).global_positions() for x in samples]),
           "skating_real_rotations": foot_skating_ratio([decode(denormalize(x)).global_positions() for x in real])}
    if classifier is not None:
        from evaluation.classifiers import run_batched

        def feats(xs):
            return run_batched(classifier, [classifier.standardize(denormalize(x)) for x in xs], "features")

        out["fd_classifier_features"] = frechet_distance(feats(samples), feats(real))
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        sk = CANONICAL.skeleton
        for c in BANDAI2_CONTENTS:
            panels = [Panel(decode(denormalize(samples[pairs.index((c, s))])).global_positions(), sk.parents, s, names=sk.names)
                      for s in STYLES]
            render_video(panels, out_dir / f"samples_{c}.mp4", CANONICAL.fps, size=(240, 240), progress=False)
    return out



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[1] / "cache" / "dataset")
    ap.add_argument("--split", default="test")
    ap.add_argument("--previews", type=Path)
    ap.add_argument("--threads", type=int, default=2)
    TextToMotion.add_options(ap)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--prior", type=Path, help="a prior's weights to measure instead of the shipped one")
    ap.add_argument("--encoder", type=Path, help="a motion encoder's weights instead of the shipped one")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from evaluation.classifiers import default_weights, load_classifier
    from mlcore.shipped import weights_path
    from transfer.bundle import ENCODER_FILE, PRIOR_FILE, MethodBundle, load_models

    if not (args.data / "features.safetensors").is_file():
        raise SystemExit(f"{args.data}: no dataset cache (video2style dataset ...)")
    m = load_models() if not (args.prior or args.encoder) else \
        MethodBundle.from_pretrained((args.prior or weights_path(PRIOR_FILE), args.encoder or weights_path(ENCODER_FILE)))
    print(f"prior: {m.prior_path}")
    data = MotionDataset(args.data, args.split)
    ret = retrieval(m.motion_encoder, m.text_encoder, data)
    for k, v in ret.items():
        print(f"{k:22s} {v if k == 'clips' else f'{100 * v:.1f} %'}")
    settings = TextToMotion.from_options(args)
    q = sample_quality(m, data, args.previews, settings=settings, classifier=load_classifier(default_weights("content")))
    for k, v in q.items():
        print(f"{k:22s} {v:.4f}" if isinstance(v, float) else f"{k:22s} {v}")
    if args.json:
        args.json.write_text(json.dumps({"retrieval": ret, "samples": q}, indent=1))


if __name__ == "__main__":
    main()
