"""The dev-styles protocol (evaluation.dev_styles) on clips the test makes: judges fitted without the examples,
identity read as the content's style and action, a transfer that becomes the target clip read as the target."""
from __future__ import annotations

import pytest
import torch

from evaluation.dev_styles import (
    RealClip,
    action_features,
    content_name,
    example_name,
    fit_judges,
    format_dev_table,
    run_dev_protocol,
)
from motioncore.representation import FEATURES

STYLES, ACTIONS = ("angry", "sad"), ("walk", "bow")


def _clip(action, style, num, seed):
    g = torch.Generator().manual_seed(seed)
    t = torch.linspace(0, 6.28, 40)[:, None]
    x = 0.05 * torch.randn(40, FEATURES.dim, generator=g)
    x[:, FEATURES.positions] += (1 + ACTIONS.index(action)) * torch.sin(t)  # actions move differently
    x[:, FEATURES.positions] += 0.5 * (1 + (STYLES + ("normal",)).index(style))  # styles hold the body elsewhere
    return RealClip(f"dataset-1_{action}_{style}_{num:03d}.bvh", action, style, x)


@pytest.fixture(scope="module")
def clips():
    out, seed = [], 0
    for a in ACTIONS:
        for s in (*STYLES, "normal"):
            for n in (1, 2, 3):
                out.append(_clip(a, s, n, seed))
                seed += 1
    return out


@pytest.mark.slow
def test_judges_leave_the_examples_out_and_read_real_clips(clips):
    judges = fit_judges(clips)
    assert judges.loo_style > 0.9 and judges.loo_action > 0.9
    assert ("walk", "angry") in judges.centres
    assert action_features(clips[0].raw).shape[0] == action_features(clips[1].raw).shape[0]


def test_identity_and_a_perfect_transfer(clips):
    judges = fit_judges(clips, leave_one_out=False)
    by_name = {c.name: c for c in clips}
    ident = run_dev_protocol(lambda s, e, a, c: c, clips, judges, STYLES, ACTIONS)
    assert ident["overall"]["style"] == 0.0 and ident["overall"]["action"] == 1.0 and ident["overall"]["moved_cm"] == 0
    perfect = run_dev_protocol(lambda s, e, a, c: by_name[f"dataset-1_{a}_{s}_002.bvh"].raw, clips, judges, STYLES, ACTIONS)
    assert perfect["overall"]["style"] == 1.0 and perfect["overall"]["action"] == 1.0 and perfect["overall"]["toward"] == 1.0
    assert set(perfect["by_style"]) == set(STYLES) and len(perfect["rows"]) == 4
    table = format_dev_table(perfect, ident)
    assert "| angry | 100 | 100 | 100 |" in table and "identity (the content)" in table
    with pytest.raises(ValueError, match="expected"):
        run_dev_protocol(lambda s, e, a, c: c[:5], clips, judges, STYLES, ACTIONS)
    assert example_name("sad") == "dataset-1_walk_sad_001.bvh" and content_name("bow") == "dataset-1_bow_normal_001.bvh"
