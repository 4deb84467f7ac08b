"""Style learning (Hu et al. §3.2-3.5) with toy models: a tiny prior and motion encoder, a hashed text encoder."""
from __future__ import annotations

import pytest
import torch

from mlcore.dataset import MotionDataset
from motioncore.representation import FEATURES
from tests.helpers import toy_learn_config
from transfer.learn import learn_style, partial_reason
from transfer.style_config import ApplyConfig
from transfer.style_file import style_model


def test_learn_style_trains_only_adapters_and_records_metadata(toys):
    bundle, cache = toys
    prior = bundle.prior
    data = MotionDataset(cache, "train")
    example = data.clip(0)
    before = {k: v.clone() for k, v in prior.state_dict().items()}
    style, info = learn_style(bundle, data, example, "elderly", "walk", toy_learn_config())
    assert all(torch.equal(before[k], v) for k, v in prior.state_dict().items())  # the prior is untouched
    assert style.meta["iterations"] == 4 and style.meta["content"] == "a person walks"
    assert style.meta["stopped_by"] == "iterations" and len(style.meta["loss_rec"]) == len(style.meta["loss_s"]) == 4
    assert info["pair"].shape == example.shape and len(info["history"]) == 4
    assert all(torch.isfinite(torch.tensor(h)).all() for h in info["history"])
    assert any(k.endswith("lora_b") and v.abs().max() > 0 for k, v in style.adapters.items())  # adapters moved from zero
    # the neutral pair keeps the example's path on the ground (inpainted root velocities)
    for sl in (FEATURES.root_rvel, FEATURES.root_lvel):
        assert torch.allclose(info["pair"][:, sl], example[:, sl], atol=1e-5)
    model = style_model(prior, style)
    x, t = torch.randn(1, 24, FEATURES.dim), torch.tensor([300])
    assert not torch.allclose(model(x, t), prior(x, t))


def test_learn_style_is_seeded_and_ablation_skips_the_pair(toys):
    bundle, cache = toys
    data = MotionDataset(cache, "train")
    a, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config())
    b, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config())
    assert all(torch.equal(a.adapters[k], b.adapters[k]) for k in a.adapters)
    _, info = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config(pair_generation=False))
    assert torch.equal(info["pair"], data.clip(1))
    with pytest.raises(ValueError, match="expected an example"):
        learn_style(bundle, data, torch.zeros(10, 5), "old", "walk", toy_learn_config())


def test_evaluation_method_learns_once_per_example(toys):
    from video2style.evaluate import OnTheFly

    bundle, cache = toys
    data = MotionDataset(cache, "train")
    method = OnTheFly(bundle, data, toy_learn_config(), seed=0)
    test = MotionDataset(cache, "test")
    style, content = test.clip(0), test.clip(3)
    out1 = method(content, style, "elderly", "walk")
    out2 = method(test.clip(5), style, "elderly", "walk")
    assert out1.shape == content.shape and torch.isfinite(out1).all() and out2.shape == test.clip(5).shape
    assert len(method.learn_seconds) == 1  # the second call reused the learned style
    method(content, test.clip(2), "elderly", "walk")  # (clip 1 is clip 0's mirrored copy: same features here)
    assert len(method.learn_seconds) == 2


def test_learning_budget_is_iterations_and_a_time_cap_is_reported(toys, monkeypatch):
    bundle, cache = toys
    data = MotionDataset(cache, "train")
    # a busy machine: every clock reading is 10 s later than the last; without a cap it changes nothing
    clock = iter(range(0, 10**6, 10))
    monkeypatch.setattr("transfer.learn.time.time", lambda: float(next(clock)))
    slow, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config())
    monkeypatch.undo()
    quick, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config())
    assert slow.meta["iterations"] == quick.meta["iterations"] == 4
    assert all(torch.equal(slow.adapters[k], quick.adapters[k]) for k in quick.adapters)
    assert partial_reason(quick.meta, min_iterations=4) is None
    assert "only 4 fine-tuning iterations, fewer than the 5" in partial_reason(quick.meta, min_iterations=5)
    capped, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config(max_seconds=1e-9))
    assert capped.meta["iterations"] == 0 and capped.meta["stopped_by"] == "time"
    assert "cut short by the time cap" in partial_reason(capped.meta, min_iterations=0)


def test_variants_that_learn_alike_share_their_styles(toys):
    from dataclasses import replace

    from video2style.evaluate import OnTheFly

    bundle, cache = toys
    data, test = MotionDataset(cache, "train"), MotionDataset(cache, "test")
    shared = {}
    regen = OnTheFly(bundle, data, toy_learn_config(), shared=shared)
    diff = OnTheFly(bundle, data, toy_learn_config(), ApplyConfig(apply_mode="difference"), strength=0.0, shared=shared)
    other = OnTheFly(bundle, data, replace(toy_learn_config(), lambda_p=0.0), shared=shared)
    content, style = test.clip(3), test.clip(0)
    regen(content, style, "elderly", "walk")
    out = diff(content, style, "elderly", "walk")
    assert len([k for k in shared if k.startswith("style")]) == 1  # the difference variant reused the style
    assert torch.allclose(out, diff._neutral(content), atol=1e-5)  # strength 0: the content as it came in
    other(content, style, "elderly", "walk")
    assert len([k for k in shared if k.startswith("style")]) == 2  # another loss: learned again
    assert regen.learn_seconds and diff.learn_seconds and diff.iterations == [4]


@pytest.mark.parametrize("kw", [{"lambda_stat": 1.0}, {"lambda_stat": 1.0, "stat_reference": "neutral"},
                                {"lambda_dir": 1.0, "lambda_s": 0.0}, {"lambda_stat_dir": 1.0}])
def test_word_free_signals_learn_and_change_the_adapters(toys, kw):
    bundle, cache = toys
    data = MotionDataset(cache, "train")
    plain, _ = learn_style(bundle, data, data.clip(1), "qwxz", "walk", toy_learn_config(lambda_dir=0.0))
    other, _ = learn_style(bundle, data, data.clip(1), "qwxz", "walk", toy_learn_config(**kw))
    assert all(torch.isfinite(v).all() for v in other.adapters.values())
    assert any(not torch.equal(plain.adapters[k], other.adapters[k]) for k in plain.adapters)
    assert other.meta["config"]["lambda_stat"] == kw.get("lambda_stat", 0.0)


def test_words_matter_only_through_the_semantic_loss(toys):
    bundle, cache = toys
    data = MotionDataset(cache, "train")
    a, _ = learn_style(bundle, data, data.clip(1), "proud", "walk", toy_learn_config(lambda_s=0.0, lambda_stat=1.0))
    b, _ = learn_style(bundle, data, data.clip(1), "qwxz", "walk", toy_learn_config(lambda_s=0.0, lambda_stat=1.0))
    assert all(torch.equal(a.adapters[k], b.adapters[k]) for k in a.adapters)
    c, _ = learn_style(bundle, data, data.clip(1), "proud", "walk", toy_learn_config())  # the defaults: word-free
    d, _ = learn_style(bundle, data, data.clip(1), "qwxz", "walk", toy_learn_config())
    assert all(torch.equal(c.adapters[k], d.adapters[k]) for k in c.adapters)
    e, _ = learn_style(bundle, data, data.clip(1), "qwxz", "walk", toy_learn_config(lambda_s=0.1))
    assert any(not torch.equal(d.adapters[k], e.adapters[k]) for k in d.adapters)  # L_s on: the words enter
    with pytest.raises(ValueError, match="expected stat_reference"):
        learn_style(bundle, data, data.clip(1), "x", "walk", toy_learn_config(lambda_stat=1.0, stat_reference="odd"))


def test_neutral_pair_is_the_one_learning_draws(toys):
    from transfer.learn import neutral_pair

    bundle, cache = toys
    data = MotionDataset(cache, "train")
    _, info = learn_style(bundle, data, data.clip(2), "old", "walk", toy_learn_config(seed=3))
    assert torch.equal(neutral_pair(bundle, data.clip(2), toy_learn_config(seed=3), "walk", dataset=data), info["pair"])
    assert not torch.equal(neutral_pair(bundle, data.clip(2), toy_learn_config(seed=4), "walk", dataset=data), info["pair"])


def test_a_long_example_gets_its_pair_drawn_in_windows_as_long_as_the_priors(toys):
    """The prior, trained on fixed windows, draws longer motion shuffling: a longer example's pair is drawn in
    ``config.window``-frame windows (crossfaded), its path kept; ``pair_windowed=False`` draws it whole."""
    from transfer.edit import TRAJECTORY
    from transfer.learn import neutral_pair

    bundle, cache = toys
    data = MotionDataset(cache, "train")
    example = torch.cat([data.clip(0), data.clip(1), data.clip(0)])[:70]
    lengths = []
    hook = bundle.prior.register_forward_hook(lambda module, args, out: lengths.append(args[0].shape[1]))
    try:
        for windowed in (True, False):
            lengths.clear()
            config = toy_learn_config(seed=1, pair_between=False, pair_windowed=windowed)
            pair = neutral_pair(bundle, example, config, "walk")
            assert pair.shape == example.shape and torch.isfinite(pair).all()
            assert set(lengths) == ({config.window} if windowed else {70})
            for s in TRAJECTORY:  # the example's path, through the crossfade too
                assert torch.allclose(pair[:, s], example[:, s], atol=1e-5)
    finally:
        hook.remove()


def test_a_bounded_pair_is_the_pair_learning_uses_and_neutral_pair_draws(toys):
    from transfer.learn import neutral_pair
    from transfer.posture import POSTURE_TOLERANCE
    from transfer.style_losses import STAT_CHANNELS

    bundle, cache = toys
    data = MotionDataset(cache, "train")
    example, config = data.clip(2), toy_learn_config(seed=3, pair_between=True)
    _, drawn = learn_style(bundle, data, example, "old", "walk", toy_learn_config(seed=3, pair_between=False))
    _, info = learn_style(bundle, data, example, "old", "walk", config)
    assert torch.equal(neutral_pair(bundle, example, config, "walk", dataset=data), info["pair"])
    neutral = [data.clip(i) for i, r in enumerate(data.records) if r.style == "normal" and r.caption == "a person walks"]
    means = torch.stack([x[:, STAT_CHANNELS].mean(0) for x in neutral])
    m_e, spread = example[:, STAT_CHANNELS].mean(0), 2 * means.std(0, unbiased=False)
    low = torch.minimum(m_e, means.mean(0) - spread) - POSTURE_TOLERANCE
    high = torch.maximum(m_e, means.mean(0) + spread) + POSTURE_TOLERANCE
    m_p = info["pair"][:, STAT_CHANNELS].mean(0)
    assert (m_p >= low - 1e-5).all() and (m_p <= high + 1e-5).all()
    shift = info["pair"] - drawn["pair"]  # the pair the prior drew, moved by a constant per body channel only
    assert shift.abs().max() > 0.1 and torch.allclose(shift, shift[:1].expand_as(shift), atol=1e-5)
    others = [i for i in range(FEATURES.dim) if i not in set(STAT_CHANNELS.tolist())]
    assert torch.equal(shift[:, others], torch.zeros_like(shift[:, others]))
    with pytest.raises(ValueError, match="content source"):
        neutral_pair(bundle, example, config, "walk")
