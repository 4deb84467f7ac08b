import math

import numpy as np
import pytest
import torch

from evaluation.metrics import (
    foot_contact_agreement,
    frechet_distance,
    gaussian_frechet,
    recognition_accuracy,
)
from motioncore.kinematics import rest_positions
from motioncore.representation import FEATURES, encode
from motioncore.skating import foot_skating_ratio, skating_frames
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion


def _samples_with_moments(n: int, mean: np.ndarray, cov: np.ndarray, seed: int) -> np.ndarray:
    """Samples whose sample mean and unbiased sample covariance are exactly ``mean`` and ``cov``."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n, mean.size))
    z -= z.mean(0)
    z = z @ np.linalg.inv(np.linalg.cholesky(np.atleast_2d(np.cov(z, rowvar=False)))).T  # whiten: cov(z) = I
    return z @ np.linalg.cholesky(cov).T + mean


def test_frechet_1d_known_value():
    # N(0, 1) vs N(3, 4): 3^2 + 1 + 4 - 2 * sqrt(1 * 4) = 10
    a = _samples_with_moments(500, np.zeros(1), np.eye(1), 0)
    b = _samples_with_moments(300, np.full(1, 3.0), 4 * np.eye(1), 1)
    assert frechet_distance(a, b) == pytest.approx(10.0, abs=1e-8)
    assert frechet_distance(torch.from_numpy(b), torch.from_numpy(a)) == pytest.approx(10.0, abs=1e-8)


def test_frechet_non_commuting_covariances():
    # S1 = I, S2 = R diag(4, 9) R^T: trace(I + S2 - 2 sqrt(S2)) = 2 + 13 - 2 * 5 = 5; means differ by (1, 2): +5
    th = 0.7
    r = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    s2 = r @ np.diag([4.0, 9.0]) @ r.T
    assert gaussian_frechet(np.zeros(2), np.eye(2), np.array([1.0, 2.0]), s2) == pytest.approx(10.0, abs=1e-9)
    a = _samples_with_moments(400, np.zeros(2), np.eye(2), 2)
    b = _samples_with_moments(400, np.array([1.0, 2.0]), s2, 3)
    assert frechet_distance(a, b) == pytest.approx(10.0, abs=1e-8)


def test_frechet_identical_sets_and_errors():
    a = np.random.default_rng(0).standard_normal((50, 8))
    assert abs(frechet_distance(a, a)) < 1e-6
    # rank-deficient covariances (fewer samples than dimensions) still give a finite value
    assert math.isfinite(frechet_distance(a[:5], a[5:10]))
    with pytest.raises(ValueError, match="feature sizes"):
        frechet_distance(a, a[:, :3])
    with pytest.raises(ValueError, match="N >= 2"):
        frechet_distance(a[:1], a)


def _feet_positions(foot_xyz: torch.Tensor) -> torch.Tensor:
    """Positions (T, J, 3): the rest pose, hips at 0.9 m, with the four contact joints placed at
    ``foot_xyz (T, 3)`` plus their rest offsets relative to the lowest one (a flat, rigid foot pair)."""
    t = foot_xyz.shape[0]
    rest = rest_positions(CANONICAL.skeleton.offsets, CANONICAL.skeleton.parents)
    rest = rest - rest[list(CANONICAL.feet), 1].min() * torch.tensor([0.0, 1.0, 0.0])
    pos = rest.expand(t, -1, -1).clone()
    feet = list(CANONICAL.feet)
    pos[:, feet] = rest[feet] + foot_xyz[:, None]
    return pos


def test_planted_foot_has_zero_skating_and_sliding_foot_has_one():
    t, fps = 40, 20.0
    planted = _feet_positions(torch.zeros(t, 3))
    assert foot_skating_ratio(planted, fps) == 0.0
    slide = torch.zeros(t, 3)
    slide[:, 0] = torch.arange(t) * 1.0 / fps  # 1 m/s along x, on the floor
    assert foot_skating_ratio(_feet_positions(slide), fps) == 1.0
    # the same slide 20 cm in the air is a swing, not a skate; heights are above each joint's lowest
    # point in the clip, so lift it only for the second half and check exactly that half is skating-free
    half = slide.clone()
    half[t // 2:, 1] = 0.2
    s = skating_frames(_feet_positions(half), fps)
    assert s[: t // 2 - 1].all() and not s[t // 2 - 1:].any()
    assert foot_skating_ratio(_feet_positions(half), fps) == pytest.approx((t // 2 - 1) / (t - 1))


def test_skating_needs_the_whole_foot_on_the_floor():
    t, fps = 30, 20.0
    slide = torch.zeros(t, 3)
    slide[:, 0] = torch.arange(t) * 1.0 / fps
    pos = _feet_positions(slide)
    foot_l, _toes_l, foot_r, toes_r = CANONICAL.feet
    heel_up = pos.clone()
    heel_up[1::2, [foot_l, foot_r], 1] += 0.1  # ankles lifted every other frame: the toes alone slide
    assert foot_skating_ratio(heel_up, fps) == 0.0
    one_foot = pos.clone()
    one_foot[:, [foot_r, toes_r]] = pos[:1, [foot_r, toes_r]]  # right foot planted, left foot slides
    assert foot_skating_ratio(one_foot, fps) == 1.0


def test_skating_thresholds_and_floor_invariance():
    t, fps = 30, 20.0
    slow = torch.zeros(t, 3)
    slow[:, 2] = torch.arange(t) * 0.4 / fps  # 0.4 m/s < 0.5 m/s threshold
    assert foot_skating_ratio(_feet_positions(slow), fps) == 0.0
    fast = torch.zeros(t, 3)
    fast[:, 2] = torch.arange(t) * 0.6 / fps
    pos = _feet_positions(fast)
    assert foot_skating_ratio(pos, fps) == 1.0
    # a clip floating 30 cm up (or sunk) is judged relative to its own floor
    assert foot_skating_ratio(pos + torch.tensor([0.0, 0.3, 0.0]), fps) == 1.0
    # pooled over clips: 29 skating + 0 skating transitions out of 58
    assert foot_skating_ratio([pos, _feet_positions(torch.zeros(t, 3))], fps) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="positions"):
        foot_skating_ratio(torch.zeros(t, 5, 3), fps)


def _static_feet_features(t: int, slide_from: int | None = None) -> torch.Tensor:
    """Raw features of a motion standing still (position features only), optionally sliding fast from a frame on."""
    pos = _feet_positions(torch.zeros(t, 3))
    if slide_from is not None:
        shift = torch.zeros(t, 3)
        shift[slide_from:, 0] = (torch.arange(t - slide_from) + 1) * 2.0 / 20.0  # 2 m/s
        pos[:, list(CANONICAL.feet)] += shift[:, None]
    f = torch.zeros(t, FEATURES.dim)
    f[:, FEATURES.root_height] = pos[:, 0, 1:2]
    f[:, FEATURES.positions] = (pos[:, 1:] - pos[:, :1] * torch.tensor([1.0, 0.0, 1.0])).flatten(1)
    return f


def test_foot_contact_agreement_known_values():
    a = _static_feet_features(40)
    assert foot_contact_agreement(a, a) == 1.0
    b = _static_feet_features(40, slide_from=20)  # feet in contact for frames < 19, sliding (no contact) after
    agreement = foot_contact_agreement(a, b)
    assert 0.45 <= agreement <= 0.55
    # the features' own contact slice: all zero in both here
    assert foot_contact_agreement(a, b, source="features") == 1.0
    # lists pool over frames; different lengths compare the common frames
    assert foot_contact_agreement([a, a], [a, b]) == pytest.approx((1 + agreement) / 2)
    assert foot_contact_agreement(a[:30], a) == 1.0


def test_foot_contact_agreement_on_a_real_motion_matches_encoded_flags():
    f = encode(random_motion(seconds=3, seed=4))
    assert foot_contact_agreement(f, f) == 1.0
    # encode's flags come from the same rule on FK positions; decoding positions reproduces them closely
    assert foot_contact_agreement(f, f.clone(), source="features") == 1.0


def test_recognition_accuracy_counts_matches():
    from evaluation.classifiers import ClassifierConfig, MotionClassifier, run_batched

    torch.manual_seed(0)
    model = MotionClassifier(ClassifierConfig(channels=[8, 8], strides=[2, 1])).eval()
    clips = [torch.randn(n, FEATURES.dim) for n in (20, 33, 41, 25)]
    pred = run_batched(model, clips).argmax(-1).tolist()
    classes = model.config.classes
    assert recognition_accuracy(model, clips, [classes[p] for p in pred]) == 1.0
    wrong = [classes[(p + 1) % len(classes)] for p in pred]
    assert recognition_accuracy(model, clips, [classes[pred[0]], classes[pred[1]]] + wrong[2:]) == 0.5
    assert recognition_accuracy(model, clips, pred) == 1.0  # indices work too
    with pytest.raises(KeyError, match="not a content class"):
        recognition_accuracy(model, clips, ["fly"] * 4)
