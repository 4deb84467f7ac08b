import pytest
import torch

from evaluation.judge import HandJudge, judge_features
from motioncore.representation import FEATURES


def _clip(t=30, height=0.9, speed=1.2, fps=20.0):
    x = torch.zeros(t, FEATURES.dim)
    x[:, FEATURES.root_height] = height
    x[:, FEATURES.root_lvel.start + 1] = speed / fps  # forward, metres per frame
    pos = torch.arange(FEATURES.positions.stop - FEATURES.positions.start, dtype=torch.float32) / 100
    x[:, FEATURES.positions] = pos
    return x


def test_judge_features_known_values():
    x = _clip()
    j = FEATURES.positions.stop - FEATURES.positions.start
    f = judge_features(x, fps=20.0)
    assert f.shape == (2 * j + j // 3 + 4,)
    assert torch.allclose(f[:j], torch.arange(j, dtype=torch.float32) / 100)  # mean places
    assert torch.count_nonzero(f[j:2 * j + j // 3]) == 0  # nothing swings or moves
    assert torch.allclose(f[-4:], torch.tensor([0.9, 0.0, 1.2, 0.0]), atol=1e-5)  # hips, their sway, speed, turning
    swing = x.clone()
    swing[::2, FEATURES.positions.start] += 0.1  # the first joint's x flips 10 cm every frame
    g = judge_features(swing, fps=20.0)
    assert abs(float(g[2 * j]) - 0.1 * 20) < 1e-4  # its speed: 2 m/s
    with pytest.raises(ValueError, match="expected raw features"):
        judge_features(torch.zeros(1, FEATURES.dim))


def test_hand_judge_reads_two_separable_styles():
    torch.manual_seed(0)
    slow = torch.stack([judge_features(_clip(speed=0.5 + 0.05 * torch.rand(()).item())) for _ in range(10)])
    fast = torch.stack([judge_features(_clip(speed=1.5 + 0.05 * torch.rand(()).item())) for _ in range(10)])
    judge = HandJudge.fit(torch.cat([slow, fast]), ["elderly"] * 10 + ["active"] * 10)
    assert judge.predict(judge_features(_clip(speed=0.55))[None]) == ["elderly"]
    assert judge.predict(judge_features(_clip(speed=1.45))[None]) == ["active"]
