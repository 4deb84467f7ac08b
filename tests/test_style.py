import pytest
import torch

from mlcore.windows import crossfade, crossfade_overlap, window_starts
from motioncore.cleanup import FeetConfig, cleanup_feet, contact_runs, eased_targets, two_bone_ik
from motioncore.kinematics import fk
from motioncore.representation import FEATURES, encode, foot_contacts
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion
from tests.helpers import tiny_denoiser, trained_style
from transfer.apply import apply_style_features
from transfer.bundle import MethodBundle
from transfer.lora import add_lora, lora_state, set_gain
from transfer.style_config import ApplyConfig, LearnConfig, strength_to_step
from transfer.style_file import Style, style_model


def test_lora_starts_as_identity_and_only_adapters_train():
    model = tiny_denoiser()
    x = torch.randn(2, 10, FEATURES.dim)
    before = model(x, torch.tensor([5, 5]))
    wrapped = add_lora(model, rank=4)
    assert len(wrapped) == 2 * 6
    assert torch.allclose(model(x, torch.tensor([5, 5])), before, atol=1e-6)
    trainable = [n for n, p in model.named_parameters() if p.requires_grad]
    assert trainable and all(n.endswith(("lora_a", "lora_b")) for n in trainable)


def test_style_file_round_trip_and_strength(tmp_path):
    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    style = Style(lora_state(model), {"rank": 8, "style": "old", "config": {}}, torch.randn(20, FEATURES.dim))
    style.save(tmp_path / "old.v2s")
    loaded = Style.load(tmp_path / "old.v2s")
    assert loaded.meta["style"] == "old" and loaded.example.shape == (20, FEATURES.dim)
    assert set(loaded.adapters) == set(style.adapters)
    for k in style.adapters:  # stored as float16
        assert torch.allclose(loaded.adapters[k], style.adapters[k], atol=1e-2)
    again = style_model(prior, loaded)
    x = torch.randn(1, 12, FEATURES.dim)
    t = torch.tensor([100])
    assert not torch.allclose(again(x, t), prior(x, t))
    set_gain(again, 0.0)
    assert torch.allclose(again(x, t), prior(x, t), atol=1e-5)


def test_bad_style_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.v2s"
    bad.write_bytes(b"not a safetensors file")
    try:
        Style.load(bad)
    except ValueError as e:
        assert str(e).startswith(str(bad)) and "not a video2style style file" in str(e)
    else:
        raise AssertionError("expected ValueError")


def test_strength_maps_to_k():
    assert strength_to_step(0.5) == 300 and strength_to_step(1.0) == 600 and strength_to_step(0.001) == 1
    for bad in (0.0, -0.1, 1.5):
        with pytest.raises(ValueError, match="strength"):
            strength_to_step(bad)


def test_apply_keeps_length_and_trajectory():
    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    x = torch.randn(150, FEATURES.dim)
    out = apply_style_features(MethodBundle(prior), model, x, LearnConfig(), ApplyConfig(), seed=0)
    assert out.shape == x.shape
    for s in (FEATURES.root_rvel, FEATURES.root_lvel):
        assert torch.allclose(out[:, s], x[:, s], atol=1e-5)
    again = apply_style_features(MethodBundle(prior), model, x, LearnConfig(), ApplyConfig(), seed=0)
    assert torch.equal(out, again)  # seeded


def test_windows_cover_and_crossfade_is_seamless():
    for n in (10, 80, 81, 150, 333):
        starts = window_starts(n, 80, 20)
        covered = torch.zeros(n, dtype=torch.bool)
        for s in starts:
            covered[s:s + 80] = True
        assert covered.all() and starts[-1] + min(80, n) == n
    ramp = torch.arange(333.0)[:, None]
    starts = window_starts(333, 80, 20)
    assert torch.allclose(crossfade([ramp[s:s + 80] for s in starts], starts, 333), ramp)
    assert crossfade_overlap(80) == 20  # the prior's windows share a quarter (learning's pair and apply alike)


def test_two_bone_ik_reaches_reachable_targets():
    m = random_motion(seconds=1.0, seed=4)
    grot, gpos = fk(m.lrot, m.lpos, CANONICAL.skeleton.parents)
    hip, knee, ankle = CANONICAL.legs[1]
    target = gpos[:, ankle] + torch.tensor([0.03, 0.05, -0.02])
    lrot = two_bone_ik(grot, gpos, m.lrot, CANONICAL.skeleton.parents, hip, knee, ankle, target)
    grot2, gpos2 = fk(lrot, m.lpos, CANONICAL.skeleton.parents)
    assert (gpos2[:, ankle] - target).norm(dim=-1).max() < 1e-4
    assert ((grot2[:, ankle] * grot[:, ankle]).sum(-1).abs() > 1 - 1e-5).all()  # foot keeps its orientation


def test_contact_runs_and_pinning():
    flags = torch.tensor([0, 1, 1, 1, 0, 0, 1, 1], dtype=torch.bool)
    assert contact_runs(flags) == [(1, 4), (6, 8)]
    ankle = torch.stack([torch.arange(8.0) * 0.1, torch.full((8,), 0.2), torch.zeros(8)], -1)
    held = ankle.clone()
    held[1:4, 0] = 0.2
    tgt = eased_targets(ankle, held, flags, bridge=2)
    assert torch.allclose(tgt[1:4, 0], torch.full((3,), 0.2))  # held where the run holds it
    assert (tgt[0] - held[1]).norm() < (ankle[0] - held[1]).norm()  # drawn towards the contact coming in


def test_cleanup_removes_sliding_of_a_planted_foot():
    m = random_motion(seconds=2.0, seed=9, amplitude=0.0)
    still = type(m)(m.skeleton, m.lrot, m.lpos[:1].expand_as(m.lpos).clone(), m.fps)
    jitter = still.lpos.clone()
    jitter[:, 0, 0] += 0.03 * torch.sin(torch.arange(m.num_frames) * 0.5)  # hips sway: feet slide with them
    swaying = type(m)(m.skeleton, m.lrot, jitter, m.fps)
    out = cleanup_feet(swaying, reference=still)
    ankle = CANONICAL.legs[0][2]
    p_before, p_after = swaying.global_positions()[:, ankle], out.global_positions()[:, ankle]
    assert p_before[:, 0].std() > 0.01 and p_after[:, 0].std() < 1e-3
    assert foot_contacts(still.global_positions(), m.fps).all()
    assert encode(out).shape == (m.num_frames, FEATURES.dim)


def _standing(frames=6, pitch_deg=0.0):
    """A canonical rest pose standing on y = 0 (toes at 0), the left foot pitched down by ``pitch_deg``."""
    from motioncore import quat
    from motioncore.kinematics import rest_positions
    from motioncore.motion import Motion

    sk = CANONICAL.skeleton
    rest = rest_positions(sk.offsets, sk.parents)
    lrot = quat.identity(frames, sk.num_joints)
    lpos = sk.offsets.expand(frames, -1, -1).clone()
    lpos[:, 0, 1] = -rest[:, 1].min() + 0.02  # 2 cm up: the ankle is 7 cm above the floor
    ankle = sk.index("Foot_L")
    lrot[:, ankle] = quat.from_axis_angle(torch.tensor([1.0, 0.0, 0.0]), torch.tensor(pitch_deg).deg2rad()).expand(frames, 4)
    return Motion(sk, lrot, lpos, 20.0)


def test_cleanup_plants_a_foot_pitched_through_the_floor_as_the_content_plants_it():
    m = _standing(pitch_deg=40.0)  # about X: the forward-pointing toes go 4 cm below the floor
    flat = _standing()  # the content stands flat on the floor
    toe, ankle = CANONICAL.skeleton.index("Toes_L"), CANONICAL.skeleton.index("Foot_L")
    before = m.global_positions()
    assert (before[:, toe, 1] < -0.03).all()
    out = cleanup_feet(m, reference=flat)  # the default: planted as the content plants it
    after = out.global_positions()
    content = flat.global_positions()
    assert torch.allclose(after[:, toe], content[:, toe], atol=2e-3)  # on the floor where the content's toes are
    assert torch.allclose(after[:, ankle], content[:, ankle], atol=2e-3)
    right = CANONICAL.skeleton.index("Toes_R")
    assert torch.allclose(after[:, right], before[:, right], atol=1e-4)  # a foot on the floor is left alone


def test_cleanup_lifts_a_foot_whose_toes_would_go_through_the_floor_and_keeps_its_pitch():
    m = _standing(pitch_deg=40.0)  # plant "style": the style's own foot, its toes lifted out of the floor
    flat = _standing()
    toe, ankle = CANONICAL.skeleton.index("Toes_L"), CANONICAL.skeleton.index("Foot_L")
    out = cleanup_feet(m, reference=flat, config=FeetConfig(plant="style"))
    grot, after = fk(out.lrot, out.lpos, CANONICAL.skeleton.parents)
    assert torch.allclose(after[:, toe, 1], torch.zeros(m.num_frames), atol=1e-3)  # on the floor, not above it
    g_before = fk(m.lrot, m.lpos, CANONICAL.skeleton.parents)[0]
    assert ((grot[:, ankle] * g_before[:, ankle]).sum(-1).abs() > 1 - 1e-5).all()  # the foot keeps its pitch


def test_cleanup_lets_the_toes_go_as_low_as_the_content_s_do():
    m = _standing(pitch_deg=40.0)
    toe = CANONICAL.skeleton.index("Toes_L")
    out = cleanup_feet(m, reference=m)  # the content itself goes that low: its floor
    assert torch.allclose(out.global_positions()[:, toe], m.global_positions()[:, toe], atol=1e-4)


def test_difference_mode_keeps_the_content_at_scale_zero_and_equals_the_delta():
    from dataclasses import replace

    from transfer.style_config import STRENGTH_AMOUNT, strength_settings

    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    x = torch.randn(90, FEATURES.dim)
    learned, diff = LearnConfig(), ApplyConfig(apply_mode="difference", style_scale=1.0)
    assert strength_settings(0.0, learned, diff) == (300, replace(diff, style_scale=0.0))
    twice = replace(diff, style_scale=STRENGTH_AMOUNT)
    assert STRENGTH_AMOUNT == 2.0  # the default amount: twice the learned difference (issue 49)
    assert strength_settings(0.5, learned, diff) == (300, twice)
    assert strength_settings(0.25, learned, diff) == (300, diff)  # once: the default before issue 49
    assert strength_settings(0.5, learned, ApplyConfig())[1].style_scale == pytest.approx(2 * 1.045)
    assert strength_settings(None, learned, diff) == (300, twice)  # the style's own setting: the default strength
    with pytest.raises(ValueError, match="strength: expected a number from 0 to 1"):
        strength_settings(1.5, learned, diff)
    bundle = MethodBundle(prior)
    assert torch.allclose(apply_style_features(bundle, model, x, learned, replace(diff, style_scale=0.0)), x, atol=1e-6)
    assert torch.allclose(apply_style_features(bundle, model, x, learned, diff, strength=0.0), x, atol=1e-6)
    one = apply_style_features(bundle, model, x, learned, diff)
    two = apply_style_features(bundle, model, x, learned, replace(diff, style_scale=2.0))
    assert torch.equal(apply_style_features(bundle, model, x, learned, diff, strength=1.0), two)  # strength 1: twice
    assert torch.allclose(two - x, 2 * (one - x), atol=1e-5)  # linear in the scale: strength moves monotonically
    # the same style through the prior alone: no difference at all
    assert torch.allclose(apply_style_features(bundle, prior, x, learned, diff), x, atol=1e-6)


def test_style_guidance_weight_one_is_the_style_model():
    from transfer.edit import StyleGuided

    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    x, t = torch.randn(1, 12, FEATURES.dim), torch.tensor([200])
    assert torch.equal(StyleGuided(prior, model, 1.0)(x, t), model(x, t))
    p, s = prior(x, t), model(x, t)
    assert torch.allclose(StyleGuided(prior, model, 2.0)(x, t), p + 2 * (s - p), atol=1e-6)


def test_reading_neutralises_only_confident_styled_clips():
    from transfer.apply import Reading

    def reading(similarity, p_content, p_styled):
        return Reading("walk", "elderly", p_content, p_styled, similarity, ())

    assert reading(0.88, 0.7, 0.95).should_neutralize()
    assert not reading(0.88, 0.7, 0.3).should_neutralize()  # a normal clip
    assert not reading(0.70, 0.7, 0.99).should_neutralize()  # a foreign clip: far from every caption
    assert not reading(0.88, 0.2, 0.99).should_neutralize()  # content unclear
    assert reading(0.70, 0.2, 0.1).should_neutralize("always") and not reading(0.88, 0.7, 0.95).should_neutralize("never")
    assert "not confident" in reading(0.70, 0.7, 0.99).describe()


def test_smooth_time_keeps_constants_and_damps_fast_oscillation():
    import math

    from transfer.edit import smooth_time

    c = torch.full((1, 40, 3), 2.5)
    assert torch.allclose(smooth_time(c, 3.0), c) and torch.equal(smooth_time(c, 0.0), c)
    t = torch.arange(80.0)
    slow, fast = torch.sin(2 * math.pi * t / 80), torch.sin(2 * math.pi * t / 8)  # 0.25 Hz and 2.5 Hz at 20 fps
    x = torch.stack([slow, fast], -1)[None]
    y = smooth_time(x, 3.0)[0, 10:-10]
    assert (y[:, 0] - slow[10:-10]).abs().max() < 0.05  # posture-like change kept
    assert y[:, 1].abs().max() < 0.1 * fast.abs().max()  # wave-like oscillation removed


def test_a_still_style_model_keeps_only_the_slow_part_of_its_difference():
    import math

    from transfer.edit import (
        STILL_SMOOTHING,
        keep_slow_when_still,
        smooth_time,
        still_share,
    )

    t = torch.arange(80.0)[None, :, None]
    base = torch.sin(2 * math.pi * t / 10).expand(2, 80, 6).clone()  # the prior's redraw: steps at 2 Hz
    moving = base * 1.1 + 0.3  # a style model that moves as much, somewhat differently
    still = 0.05 * base + 0.3  # ... one that collapsed onto a still pose
    half = 0.55 * base + 0.3  # halfway between the two ends of STILL_RATIO
    torch.testing.assert_close(still_share(torch.cat([moving[:1], still[:1]]), base), torch.tensor([1.0, 0.0]))
    assert float(still_share(half[:1], base[:1])) == pytest.approx(0.5, abs=1e-4)
    delta = torch.cat([moving[:1], still[:1]]) - base
    out = keep_slow_when_still(delta, torch.cat([moving[:1], still[:1]]), base)
    assert torch.equal(out[0], delta[0])  # a moving style keeps all of its difference
    torch.testing.assert_close(out[1], smooth_time(delta[1:], STILL_SMOOTHING)[0])  # a still one its slow part
    assert out[1, 10:-10].std(0).max() < 0.2 * delta[1].std(0).max()  # which no longer cancels the steps
    assert torch.equal(keep_slow_when_still(delta[:1], moving[:1], base[:1]), delta[:1])
    with pytest.raises(ValueError, match="expected styled and base"):
        still_share(moving[0], base[0])


@pytest.mark.slow
def test_the_shipped_caption_table_is_what_the_encoder_gives_and_apply_needs_no_model():
    import torch

    from transfer.text_encoder import LazyTextEncoder, TextEncoder, standard_captions

    lazy = LazyTextEncoder()
    texts = standard_captions()
    table = lazy.encode(texts)
    assert not lazy.loaded  # apply's captions never load sentence-transformers
    assert torch.allclose(table, TextEncoder().encode(texts), atol=1e-5)  # regenerate: transfer.text_encoder.write_caption_table
    lazy.encode(["a person juggles, pirate style"])
    assert lazy.loaded


def test_reconstruction_loss_over_several_windows_is_their_mean():
    """L_rec on a batch of windows (LearnConfig.rec_windows) averages the windows' losses: with a model that
    predicts zeros the noise does not matter, so the batch's loss is the mean of the single-window ones."""
    from transfer.learn import reconstruction_loss
    from transfer.scheduler import DiffusionScheduler

    class Zeros(torch.nn.Module):
        def forward(self, x_t, t, text=None, valid=None):
            assert t.shape == (x_t.shape[0],)
            return torch.zeros_like(x_t)

    torch.manual_seed(0)
    a, b = torch.randn(2, 1, 40, FEATURES.dim).unbind(0)
    sched, cfg = DiffusionScheduler(), LearnConfig()
    one = [reconstruction_loss(Zeros(), sched, w, w, cfg, torch.Generator().manual_seed(1)) for w in (a, b)]
    both = reconstruction_loss(Zeros(), sched, torch.cat([a, b]), torch.cat([a, b]), cfg, torch.Generator().manual_seed(1))
    assert torch.allclose(both, (one[0] + one[1]) / 2, atol=1e-6)
    with pytest.raises(ValueError, match="expected m_n and m_s"):
        reconstruction_loss(Zeros(), sched, a, torch.cat([a, b]), cfg, torch.Generator())


def test_match_posture_moves_the_time_mean_only():
    from transfer.posture import match_posture
    from transfer.style_losses import STAT_CHANNELS

    torch.manual_seed(0)
    content = torch.randn(40, FEATURES.dim)
    out = content + 0.1 * torch.randn(40, FEATURES.dim)
    shift = torch.randn(len(STAT_CHANNELS))
    ch = STAT_CHANNELS
    same = match_posture(out, content, shift, 0.0)
    assert torch.equal(same, out)
    full = match_posture(out, content, shift, 1.0, amount=0.5)
    assert torch.allclose(full[:, ch].mean(0) - content[:, ch].mean(0), 0.5 * shift, atol=1e-5)
    assert torch.allclose(full - full.mean(0), out - out.mean(0), atol=1e-5)  # how it moves: unchanged
    others = torch.ones(FEATURES.dim, dtype=torch.bool)
    others[ch] = False
    assert torch.equal(full[:, others], out[:, others])  # root path and contacts untouched
    half = match_posture(out, content, shift, 0.5)
    change = out[:, ch].mean(0) - content[:, ch].mean(0)
    assert torch.allclose(half[:, ch].mean(0) - content[:, ch].mean(0), 0.5 * change + 0.5 * shift, atol=1e-5)
    with pytest.raises(ValueError, match="expected a shift"):
        match_posture(out, content, shift[:3], 1.0)
