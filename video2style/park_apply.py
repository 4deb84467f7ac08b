"""``video2style apply --method park``: Park et al.'s multi-domain stylizer (:mod:`park`) over BVH files.

Style codes come from noise (``seed``, several variants at once), from a reference clip, or
from interpolating two codes (two seeds in one domain, or one seed in two domains). Output goes
the same way as the main method: foot cleanup, BVH on the clip's own skeleton, a preview.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import torch

from mlcore.shipped import weights_path
from motioncore.ik_fit import decode_via_positions
from motioncore.motion import Motion
from motioncore.representation import encode, facing_angle
from motioncore.skating import motion_skating
from transfer.apply import cleanup_feet_measured
from video2style.pipeline import Clip, read_clip, write_outputs
from video2style.result import ApplyResult


@lru_cache(maxsize=2)
def park_model(path: Path | None = None, device: str = "cpu"):
    """:func:`park.infer.load_park` of ``path`` (default: the shipped ``park_stylizer.safetensors``), cached."""
    from park.infer import load_park

    return load_park(path or weights_path("park_stylizer.safetensors"), device)


MAX_VARIANTS = 64  # outputs per clip: each is a BVH and a preview panel


@dataclass
class ParkRequest:
    """What to generate: ``domain`` plus one style source (noise by default, or ``reference``), optionally ``mix``."""

    domain: str
    seed: int = 0
    variants: int = 1
    reference: Path | None = None
    mix: str | None = None  # another domain, or another seed (an integer) in the same domain
    mix_steps: int = 5

    def validate(self, domains: list[str]) -> None:
        if self.domain not in domains:
            raise ValueError(f"--domain: expected one of {', '.join(domains)}, got {self.domain!r}")
        if not 1 <= self.variants <= MAX_VARIANTS:
            raise ValueError(f"--variants: expected 1 to {MAX_VARIANTS}, got {self.variants}")
        if not 2 <= self.mix_steps <= MAX_VARIANTS:
            raise ValueError(f"--mix-steps: expected 2 to {MAX_VARIANTS}, got {self.mix_steps}")
        if self.mix is not None:
            if self.reference is not None:
                raise ValueError("--mix: interpolates noise codes; it cannot be combined with --reference")
            if self.mix not in domains:  # a seed, in the range --seed takes
                from transfer.style_config import check_config_value

                try:
                    check_config_value("seed", int(self.mix))
                except ValueError:
                    raise ValueError(f"--mix: expected a domain ({', '.join(domains)}) or an integer seed (the range "
                                     f"--seed takes), got {self.mix[:40]!r}") from None


def style_codes(model, request: ParkRequest, joint_map: dict | None = None) -> list[tuple[torch.Tensor, str]]:
    """``[(code (style_dim,), tag)]`` for the request."""
    from park.infer import code_from_noise, code_from_reference, mixed_code

    request.validate(list(model.config.domains))
    if request.reference is not None:
        ref = read_clip(request.reference, joint_map).canonical
        x = (encode(ref) - model.mean.cpu()) / model.std.cpu()
        return [(code_from_reference(model, x, request.domain), f"{request.domain}-ref")]
    if request.mix is not None:
        a = code_from_noise(model, request.domain, request.seed)[0]
        if request.mix.lstrip("-").isdigit():
            b, tag_b = code_from_noise(model, request.domain, int(request.mix))[0], f"seed{request.mix}"
        else:
            b, tag_b = code_from_noise(model, request.mix, request.seed)[0], request.mix
        alphas = torch.linspace(0, 1, request.mix_steps).tolist()
        return [(mixed_code(a, b, alpha), f"{request.domain}-{tag_b}-{alpha:.2f}") for alpha in alphas]
    codes = code_from_noise(model, request.domain, request.seed, request.variants)
    return [(c, f"{request.domain}-s{request.seed + i}" if request.variants > 1 else request.domain) for i, c in enumerate(codes)]


def stylize_clip(model, clip: Clip, codes: list[tuple[torch.Tensor, str]], clean: bool = True,
                 foot_ratios: list | None = None) -> list[tuple[Motion, str]]:
    """Each code applied to the clip's canonical motion -> ``[(motion, tag)]`` on the content's path.

    With ``clean`` the feet are cleaned by IK; ``foot_ratios``, if given, receives each output's skating ratios.
    """
    from park.infer import generate

    content = clip.canonical
    mean, std = model.mean.cpu(), model.std.cpu()  # the motion code runs on the CPU, the model anywhere
    x = (encode(content) - mean) / std
    p0 = content.global_positions()[:1].double()
    start = {"start_yaw": float(facing_angle(p0)[0]), "start_xz": (float(p0[0, 0, 0]), float(p0[0, 0, 2]))}
    out = []
    for code, tag in codes:
        feats = generate(model, x, code) * std + mean
        motion = decode_via_positions(feats, content.fps, **start)  # its position channels are the better ones
        if clean:
            motion, ratios = cleanup_feet_measured(motion, content)
            if foot_ratios is not None:
                foot_ratios.append(ratios)
        out.append((motion, tag))
    return out


def apply_park_file(model, path: Path, out_dir: Path, request: ParkRequest, joint_map: dict | None = None,
                    preview: bool = True) -> ApplyResult:
    """Stylise one BVH with Park et al.'s stylizer; writes ``out_dir/<name>[_<tag>].bvh`` and a preview. The
    result's skating ratios are the worst of its variants'."""
    t0 = time.time()
    clip = read_clip(path, joint_map)
    codes = style_codes(model, request, joint_map)
    ratios: list[dict] = []
    results = stylize_clip(model, clip, codes, foot_ratios=ratios)
    result = ApplyResult(str(path), frames=clip.canonical.num_frames, seconds_transfer=time.time() - t0,
                         skating_before=max(r["skating_before"] for r in ratios),
                         skating_after=max(r["skating_after"] for r in ratios),
                         skating_content=motion_skating(clip.canonical))
    written = write_outputs(clip, results, Path(out_dir), preview=preview)
    result.add_files(written)
    result.seconds = time.time() - t0
    return result
