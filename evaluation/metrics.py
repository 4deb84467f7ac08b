"""Motion style transfer metrics: FMD, recognition accuracy (CRA/SRA), foot contact agreement (foot skating is
:func:`motioncore.skating.foot_skating_ratio`, which apply reports too).

After Hu et al. 2024 §4.2 (FMD, CRA, SRA, following Jang et al. 2022) and Villegas et al. 2021
(foot contact accuracy). Every metric is applied identically to real and generated motion.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg
import torch

from motioncore.limbs import LIMBS, limb_places, limb_stray  # noqa: F401 - the stray measure, re-exported
from motioncore.representation import FEATURES, decode_positions, foot_contacts
from motioncore.skeleton import CANONICAL


def _as_2d(x, name: str) -> np.ndarray:
    a = x.detach().cpu().double().numpy() if torch.is_tensor(x) else np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] < 2:
        raise ValueError(f"frechet_distance: expected {name} as (N >= 2, D), got {a.shape}")
    return a


def gaussian_frechet(mu1: np.ndarray, sigma1: np.ndarray, mu2: np.ndarray, sigma2: np.ndarray, eps: float = 1e-6) -> float:
    """Fréchet distance of two Gaussians: ``|mu1 - mu2|^2 + tr(S1 + S2 - 2 (S1 S2)^(1/2))``."""
    mu1, mu2 = np.atleast_1d(mu1).astype(np.float64), np.atleast_1d(mu2).astype(np.float64)
    s1, s2 = np.atleast_2d(sigma1).astype(np.float64), np.atleast_2d(sigma2).astype(np.float64)
    if mu1.shape != mu2.shape or s1.shape != s2.shape or s1.shape != (mu1.size, mu1.size):
        raise ValueError(f"gaussian_frechet: shapes differ: {mu1.shape}, {mu2.shape}, {s1.shape}, {s2.shape}")
    covmean = scipy.linalg.sqrtm(s1 @ s2)
    if not np.isfinite(covmean).all():  # singular product: regularise both (as pytorch-fid does)
        offset = np.eye(s1.shape[0]) * eps
        covmean = scipy.linalg.sqrtm((s1 + offset) @ (s2 + offset))
    if np.iscomplexobj(covmean):
        covmean = covmean.real  # round-off gives tiny imaginary parts
    diff = mu1 - mu2
    return float(diff @ diff + np.trace(s1) + np.trace(s2) - 2.0 * np.trace(covmean))


def frechet_distance(feats_a, feats_b) -> float:
    """Fréchet distance between Gaussians fitted to two feature sets ``(N, D)`` and ``(M, D)``.

    FMD is this on the content classifier's pooled features (``MotionClassifier.features``) of
    real and generated motions. Covariances are unbiased (``np.cov``); the value depends on N and
    M, so compare FMDs only between sets of the same sizes.
    """
    a, b = _as_2d(feats_a, "feats_a"), _as_2d(feats_b, "feats_b")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"frechet_distance: feature sizes differ: {a.shape[1]} vs {b.shape[1]}")
    return gaussian_frechet(a.mean(0), np.cov(a, rowvar=False), b.mean(0), np.cov(b, rowvar=False))


def recognition_accuracy(classifier, motions: Sequence[torch.Tensor], labels: Sequence[str | int], batch_size: int = 32) -> float:
    """Fraction of ``motions`` that ``classifier`` assigns to ``labels`` (class names or indices).

    ``motions``: whole clips ``(T_i, D)`` normalised for the classifier (``classifier.normalize``
    on raw features). CRA is this with the content classifier and the content clips' labels, SRA
    with the style classifier and the target styles.
    """
    from evaluation.classifiers import run_batched

    if len(motions) != len(labels):
        raise ValueError(f"recognition_accuracy: {len(motions)} motions but {len(labels)} labels")
    y = classifier.label_index(labels)
    pred = run_batched(classifier, motions, "logits", batch_size).argmax(-1)
    return float((pred == y).float().mean())


def _contacts(feats: torch.Tensor, fps: float, source: str) -> torch.Tensor:
    if feats.ndim != 2 or feats.shape[1] != FEATURES.dim:
        raise ValueError(f"foot_contact_agreement: expected raw features (T, {FEATURES.dim}), got {tuple(feats.shape)}")
    if source == "positions":
        return foot_contacts(decode_positions(feats.double()), fps).bool()
    if source == "features":
        return feats[:, FEATURES.contacts] > 0.5
    raise ValueError(f"foot_contact_agreement: source must be 'positions' or 'features', got {source!r}")


def foot_contact_agreement(feats_a: torch.Tensor | Sequence[torch.Tensor], feats_b: torch.Tensor | Sequence[torch.Tensor],
                           fps: float = CANONICAL.fps, source: str = "positions") -> float:
    """Fraction of (frame, contact joint) pairs whose contact flags agree between two motions.

    ``feats_a``, ``feats_b``: *raw* (un-normalised) features ``(T, D)``, or equal-length lists of
    them (pooled over all frames). With ``source="positions"`` (default) the four flags are
    recomputed from the motion itself: ``foot_contacts(decode_positions(feats), fps)`` (height and
    speed thresholds of ``motioncore.representation``), so a model's own contact channel cannot
    flatter it; ``source="features"`` reads the features' contact slice (> 0.5). Motions of
    different lengths are compared over the shorter one's frames (transfer keeps the length).
    Foot contact accuracy after Villegas et al. 2021, used for content preservation.
    """
    a_list = [feats_a] if torch.is_tensor(feats_a) else list(feats_a)
    b_list = [feats_b] if torch.is_tensor(feats_b) else list(feats_b)
    if len(a_list) != len(b_list) or not a_list:
        raise ValueError(f"foot_contact_agreement: expected equal, non-empty lists, got {len(a_list)} and {len(b_list)}")
    agree = total = 0
    for a, b in zip(a_list, b_list):
        t = min(a.shape[0], b.shape[0])
        ca, cb = _contacts(a, fps, source)[:t], _contacts(b, fps, source)[:t]
        agree += int((ca == cb).sum())
        total += ca.numel()
    return agree / total


def trunk_lean(motion) -> float:
    """Median forward lean of a canonical ``motion``'s trunk in degrees: Hips -> Neck against the vertical, in the
    hips' facing frame (:func:`motioncore.representation.facing_frame`); positive leans forward."""
    import torch

    from motioncore.representation import facing_frame
    from motioncore.skeleton import CANONICAL

    names = CANONICAL.skeleton.names
    if tuple(motion.skeleton.names) != tuple(names):
        raise ValueError(f"trunk_lean: expected a motion on the canonical skeleton, got joints {motion.skeleton.names[:3]}...")
    gpos = motion.global_positions().float()
    _, rel = facing_frame(gpos)  # joints 1.. relative to the root's ground point: x left, y up, z forward
    v = rel[:, names.index("Neck") - 1] - torch.stack([torch.zeros_like(gpos[:, 0, 1]), gpos[:, 0, 1],
                                                       torch.zeros_like(gpos[:, 0, 1])], -1)
    return float(torch.rad2deg(torch.atan2(v[:, 2], v[:, 1])).median())


STEP_GAP = 0.2  # seconds: a foot's contacts closer than this are one step (a heel set down, lifted and set down again)


def _steps(flags: list[bool], gap: int) -> int:
    """How many steps one foot's contact ``flags`` set down: contacts that begin after the foot was lifted (one it
    stands in from the first frame is not a step), those less than ``gap`` frames after the last one ended joined."""
    steps, last_end = 0, None
    for i, f in enumerate(flags):
        if f and i > 0 and not flags[i - 1] and (last_end is None or i - last_end >= gap):
            steps += 1
        if not f and i > 0 and flags[i - 1]:
            last_end = i
    return steps


def gait_measures(motion) -> dict:
    """What an animator sees change in a walk of a canonical ``motion`` (at least a second long):

    - ``lean_deg``: the trunk's median forward lean (:func:`trunk_lean`);
    - ``arm_swing_cm``: how far the hands swing forward and back about the hips, in the hips' facing frame (each hand's
      5th-95th percentile range of its forward place, mean of both hands);
    - ``step_cm``: ground distance travelled per step (a step: a foot's contact starting, either foot);
    - ``cadence_spm``: steps per minute.

    Steps come from the ankles' contacts (:func:`motioncore.representation.foot_contacts`), a foot's contacts less
    than :data:`STEP_GAP` apart counted as one; a clip without two steps gives NaN for both step measures."""
    import math

    import torch

    from motioncore.representation import facing_frame, foot_contacts
    from motioncore.skeleton import CANONICAL

    names = CANONICAL.skeleton.names
    if tuple(motion.skeleton.names) != tuple(names):
        raise ValueError(f"gait_measures: expected a motion on the canonical skeleton, got joints {motion.skeleton.names[:3]}...")
    if motion.num_frames < motion.fps:
        raise ValueError(f"gait_measures: expected at least a second of motion, got {motion.num_frames} frames")
    gpos = motion.global_positions().float()
    _, rel = facing_frame(gpos)  # joints 1.. relative to the root's ground point: x left, y up, z forward
    swing = []
    for hand in ("Hand_L", "Hand_R"):
        z = rel[:, names.index(hand) - 1, 2]
        swing.append(float(torch.quantile(z, 0.95) - torch.quantile(z, 0.05)))
    contacts = foot_contacts(gpos, motion.fps)[:, [0, 2]] > 0.5  # the ankles
    onsets = sum(_steps(contacts[:, side].tolist(), round(STEP_GAP * motion.fps)) for side in range(2))
    travelled = float((gpos[1:, 0, [0, 2]] - gpos[:-1, 0, [0, 2]]).norm(dim=-1).sum())
    seconds = motion.num_frames / motion.fps
    steps_ok = onsets >= 2
    return {"lean_deg": trunk_lean(motion), "arm_swing_cm": 100 * sum(swing) / 2,
            "step_cm": 100 * travelled / onsets if steps_ok else math.nan,
            "cadence_spm": 60 * onsets / seconds if steps_ok else math.nan}
