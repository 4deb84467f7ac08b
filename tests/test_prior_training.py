"""The prior's training recipe: styles left out, a validation loss, resumed runs keeping their own settings."""
from __future__ import annotations

import pytest
import torch

from mlcore.dataset import MotionDataset
from tests.synthetic_cache import write_synthetic_cache
from transfer.prior import (
    PriorTrainConfig,
    convergence,
    load_prior,
    read_val_log,
    train_prior,
)

TINY = {"width": 32, "layers": 1, "heads": 2, "ff": 64, "batch_size": 4, "window": 24, "warmup": 2, "val_every": 2,
        "val_windows": 6}


def _cache(tmp_path):
    return write_synthetic_cache(tmp_path / "cache", styles=("normal", "elderly", "feminine"))


def test_excluded_styles_leave_no_clip_and_bad_names_are_refused(tmp_path):
    cache = _cache(tmp_path)
    full = MotionDataset(cache, "train")
    kept = MotionDataset(cache, "train", exclude_styles=("elderly",))
    assert {r.style for r in full.records} == {"normal", "elderly", "feminine"}
    assert {r.style for r in kept.records} == {"normal", "feminine"}
    assert not any("elderly" in r.caption for r in kept.records)
    assert torch.equal(kept.mean, full.mean)  # the normaliser stays the cache's
    with pytest.raises(ValueError, match="expected styles among"):
        MotionDataset(cache, "train", exclude_styles=("grumpy",))
    with pytest.raises(ValueError, match="neutral style 'normal' cannot be excluded"):
        MotionDataset(cache, "train", exclude_styles=("normal",))


def test_tiny_run_logs_a_fixed_validation_loss_and_resumes_with_its_own_settings(tmp_path):
    cache, out = _cache(tmp_path), tmp_path / "run"
    explicit = {**TINY, "exclude_styles": ("elderly",)}
    train_prior(cache, out, PriorTrainConfig(**explicit), max_minutes=5, max_steps=4, explicit=explicit, progress=False)
    log = read_val_log(out / "val.csv")
    assert [s for s, _ in log] == [2, 4]
    assert all(v > 0 for _, v in log)
    # Resumed with no settings given: the checkpoint's own (width 32, elderly left out), not the defaults.
    trainer = train_prior(cache, out, PriorTrainConfig(), max_minutes=5, max_steps=6, explicit={}, progress=False)
    assert trainer.step == 6
    assert trainer.config.width == 32 and tuple(trainer.config.exclude_styles) == ("elderly",)
    assert [s for s, _ in read_val_log(out / "val.csv")] == [2, 4, 6]
    model, _, _ = load_prior(out / "denoiser.safetensors")
    assert model.config.width == 32
    card = (out / "denoiser.json").read_text()
    assert "elderly left out" in card and "validation_loss" in card
    with pytest.raises(ValueError, match="cannot resume with different settings.*exclude_styles"):
        other = {"exclude_styles": ("feminine",)}
        train_prior(cache, out, PriorTrainConfig(**{**TINY, **other}), max_minutes=5, max_steps=8, explicit=other,
                    progress=False)


def test_validation_loss_is_the_same_for_the_same_model(tmp_path):
    from transfer.denoiser import Denoiser, DenoiserConfig
    from transfer.prior import ValidationLoss
    from transfer.scheduler import DiffusionScheduler

    data = MotionDataset(_cache(tmp_path), "val")
    text = torch.randn(len(data), 384)
    torch.manual_seed(0)
    model = Denoiser(DenoiserConfig(width=32, layers=1, heads=2, ff=64)).train()
    make = lambda: ValidationLoss(data, text, DiffusionScheduler(1000), 8, 24, 1.0)
    first, second = make()(model), make()(model)
    assert first == second and model.training  # fixed windows, noise and steps; no dropout; mode restored


def test_convergence_is_the_fall_over_the_last_fifth():
    log = [(100 * i, v) for i, v in enumerate([1.0, 0.5, 0.4, 0.3, 0.25, 0.2, 0.18, 0.17, 0.165, 0.16, 0.158])]
    # last step 1000, a fifth back is step 800 (0.165): (0.165 - 0.158) / 0.165
    assert convergence(log) == pytest.approx((0.165 - 0.158) / 0.165)
    assert convergence(log[:2]) is None
    assert read_val_log("/nonexistent/val.csv") == []


def test_bf16_steps_train_and_the_validation_loss_matches_fp32_at_the_same_weights(tmp_path):
    """precision "bf16" runs the training forward under autocast: a tiny run trains (finite, falling loss), its
    checkpoint records the setting, and the loss of one batch is within bfloat16's rounding of fp32's."""
    from transfer.denoiser import Denoiser, DenoiserConfig
    from transfer.prior import diffusion_loss
    from transfer.scheduler import DiffusionScheduler

    cache, out = _cache(tmp_path), tmp_path / "run"
    explicit = {**TINY, "precision": "bf16"}
    trainer = train_prior(cache, out, PriorTrainConfig(**explicit), max_minutes=5, max_steps=4, explicit=explicit,
                          progress=False)
    assert trainer.config.precision == "bf16" and trainer.step == 4
    assert all(0 < v < float("inf") for _, v in read_val_log(out / "val.csv"))
    torch.manual_seed(0)
    model = Denoiser(DenoiserConfig(width=32, layers=1, heads=2, ff=64, dropout=0.0))
    args = (torch.randn(4, 24, model.config.feature_dim), torch.ones(4, 24, dtype=torch.bool), torch.randn(4, 384),
            torch.zeros(4, dtype=torch.bool), 1.0)
    losses = {p: diffusion_loss(model, DiffusionScheduler(), *args[:4], args[4], torch.Generator().manual_seed(1), p)[0]
              for p in ("fp32", "bf16")}
    assert abs(float(losses["bf16"] - losses["fp32"])) < 0.02 * float(losses["fp32"])
    with pytest.raises(ValueError, match="expected precision"):
        diffusion_loss(model, DiffusionScheduler(), *args[:4], args[4], torch.Generator(), "fp16")


def test_positions_from_rotations_equal_the_position_channels_of_encoded_clips():
    """The FK consistency term is zero on real features: FK of the rotation channels and root height puts every
    joint where the position channels do (the facing frame, the root's ground point at the origin)."""
    from motioncore.representation import FEATURES, encode, positions_from_rotations
    from testkit.motions import random_motion

    feats = encode(random_motion(seconds=2, seed=3))
    implied = positions_from_rotations(feats.double())
    held = feats[:, FEATURES.positions].double().unflatten(-1, (-1, 3))
    assert implied.shape == held.shape
    assert (implied - held).abs().max() < 1e-4  # metres; float32 features
    batched = positions_from_rotations(torch.stack([feats, feats]))  # any leading dims
    assert batched.shape == (2, *held.shape)
    with pytest.raises(ValueError, match="expected"):
        positions_from_rotations(feats[:, :-1])


def test_derived_position_channels_leave_an_encoded_clip_as_it_was_and_replace_only_the_position_channels():
    """Text-to-motion's derivation (:func:`transfer.denoiser.derive_position_channels`) on normalised features: a real
    clip's channels already agree, so it comes back unchanged; a clip with moved position channels gets them back."""
    from motioncore.representation import FEATURES, encode
    from testkit.motions import random_motion
    from transfer.denoiser import derive_position_channels

    feats = encode(random_motion(seconds=2, seed=4))
    g = torch.Generator().manual_seed(0)
    mean, std = torch.randn(FEATURES.dim, generator=g) * 0.1, torch.rand(FEATURES.dim, generator=g) + 0.5
    x0 = ((feats - mean) / std)[None]
    assert torch.allclose(derive_position_channels(x0, mean, std), x0, atol=1e-3)
    moved = x0.clone()
    moved[..., FEATURES.positions] += 0.3
    restored = derive_position_channels(moved, mean, std)
    assert torch.allclose(restored, x0, atol=1e-3)
    with pytest.raises(ValueError, match="expected x0"):
        derive_position_channels(x0[..., :-1], mean, std)


def test_fk_loss_is_zero_on_real_features_and_grows_with_a_bent_joint():
    from motioncore.representation import FEATURES, encode
    from testkit.motions import random_motion
    from transfer.prior import fk_loss

    x = encode(random_motion(seconds=1.5, seed=1))[None]
    mean, std = torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim)
    valid = torch.ones(1, 30, dtype=torch.bool)
    assert float(fk_loss(x, x, valid, mean, std)) < 1e-4  # cm^2
    bent = x.clone()
    bent[..., FEATURES.rotations.start + 6 * 2: FEATURES.rotations.start + 6 * 3] = torch.tensor(
        [0.0, 1.0, 0.0, -1.0, 0.0, 0.0])  # joint 2 turned 90 degrees: everything above it moves
    assert float(fk_loss(bent, x, valid, mean, std)) > 10.0
    with pytest.raises(ValueError, match="expected"):
        fk_loss(x[..., :-1], x[..., :-1], valid, mean[:-1], std[:-1])


def test_feet_velocity_is_the_feet_travel_over_the_ground_in_the_facing_frame():
    """Known values: against the global joint positions that decoding the position channels gives, differenced and
    turned into each frame's facing frame; from the rotation channels (FK) the same on encoded clips."""
    from motioncore import quat
    from motioncore.representation import (
        FEATURES,
        decode_positions,
        encode,
        feet_velocity,
        positions_from_rotations,
    )
    from motioncore.skeleton import CANONICAL
    from testkit.motions import random_motion

    feats = encode(random_motion(seconds=2, seed=4)).double()
    g = decode_positions(feats)[:, list(CANONICAL.feet)]
    rvel = feats[:, FEATURES.root_rvel.start]
    yaw = torch.cumsum(rvel, 0) - rvel
    expected = quat.mul_vec(quat.from_yaw(-yaw[:-1])[:, None], g[1:] - g[:-1])
    assert (feet_velocity(feats) - expected).abs().max() < 1e-9
    assert (feet_velocity(feats, positions_from_rotations(feats)) - expected).abs().max() < 1e-4
    assert feet_velocity(torch.stack([feats, feats])).shape == (2, feats.shape[0] - 1, 4, 3)
    with pytest.raises(ValueError, match="expected"):
        feet_velocity(feats[:1])


def test_contact_loss_is_zero_for_planted_feet_and_grows_when_the_root_slides_under_them():
    from motioncore.representation import FEATURES, encode
    from testkit.motions import random_motion
    from transfer.prior import contact_loss

    m = random_motion(seconds=2, seed=1, amplitude=0.0)
    x = encode(type(m)(m.skeleton, m.lrot[:1].expand_as(m.lrot).clone(), m.lpos[:1].expand_as(m.lpos).clone(),
                       m.fps))[None]  # one pose held: the feet are planted
    assert x[..., FEATURES.contacts].mean() > 0.5
    mean, std = torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim)
    valid = torch.ones(x.shape[:2], dtype=torch.bool)
    assert float(contact_loss(x, valid, mean, std)) < 1e-6
    sliding = x.clone()
    sliding[..., FEATURES.root_lvel.start] += 0.02  # 2 cm a frame forward while the feet say they are planted
    assert float(contact_loss(sliding, valid, mean, std)) == pytest.approx(4.0 / 3, rel=1e-3)  # (cm/frame)^2 per axis
    lifted = sliding.clone()
    lifted[..., FEATURES.contacts] = 0.0  # feet in the air may move
    assert float(contact_loss(lifted, valid, mean, std)) == 0.0
    assert float(contact_loss(sliding, torch.zeros_like(valid), mean, std)) == 0.0  # nothing valid
    with pytest.raises(ValueError, match="expected"):
        contact_loss(x[..., :-1], valid, mean[:-1], std[:-1])


def test_contact_guide_plants_sliding_feet_clip_by_clip_and_leaves_planted_ones():
    from motioncore.representation import FEATURES, encode
    from testkit.motions import random_motion
    from transfer.prior import contact_guide, contact_loss

    m = random_motion(seconds=2, seed=1, amplitude=0.0)
    x = encode(type(m)(m.skeleton, m.lrot[:1].expand_as(m.lrot).clone(), m.lpos[:1].expand_as(m.lpos).clone(),
                       m.fps))[None]  # one pose held: the feet are planted
    mean, std = torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim)
    valid = torch.ones(x.shape[:2], dtype=torch.bool)
    sliding = x.clone()
    sliding[..., FEATURES.root_lvel.start] += 0.02
    guide = contact_guide(mean, std, rate=0.002, iterations=2)  # a step for metre-scale features (std 1)
    with torch.no_grad():  # as the sampler calls it
        planted = guide(sliding)
    before, after = float(contact_loss(sliding, valid, mean, std)), float(contact_loss(planted, valid, mean, std))
    assert after < 0.5 * before  # the guide moves the draw towards planted feet
    assert not planted.requires_grad and planted.shape == sliding.shape
    assert torch.allclose(guide(x), x, atol=1e-6)  # planted feet: nothing to correct
    assert torch.equal(contact_guide(mean, std, 0.002, 0)(sliding), sliding)
    pair = guide(torch.cat([sliding, x]))  # a clip's correction does not depend on the others in its batch
    assert torch.allclose(pair[:1], planted, atol=1e-6)
    with pytest.raises(ValueError, match="expected"):
        contact_guide(mean, std, -1.0, 2)


def test_fk_weight_is_a_stage_a_finished_run_may_resume_with_and_its_log_gains_the_column(tmp_path):
    import csv

    cache, out = _cache(tmp_path), tmp_path / "run"
    train_prior(cache, out, PriorTrainConfig(**TINY), max_minutes=5, max_steps=3, explicit=dict(TINY), progress=False)
    stage = {"fk_weight": 0.05, "contact_weight": 0.5, "precision": "bf16"}
    trainer = train_prior(cache, out, PriorTrainConfig(**stage), max_minutes=5, max_steps=5, explicit=stage,
                          progress=False)
    assert trainer.step == 5 and trainer.config.fk_weight == 0.05 and trainer.config.width == 32
    assert trainer.config.contact_weight == 0.5
    with open(out / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["step"]) for r in rows] == [1, 2, 3, 4, 5]
    assert [r["fk"] for r in rows[:3]] == ["", "", ""] and all(float(r["fk"]) >= 0 for r in rows[3:])
    assert [r["contact"] for r in rows[:3]] == ["", "", ""] and all(float(r["contact"]) >= 0 for r in rows[3:])
    with pytest.raises(ValueError, match="cannot resume with different settings.*width"):
        train_prior(cache, out, PriorTrainConfig(width=64), max_minutes=5, max_steps=6, explicit={"width": 64},
                    progress=False)
    # a new learning-rate schedule is a stage too: the rate of step 6 is the new one's
    schedule = {"lr": 5e-4, "decay_start": 6, "decay_steps": 4, "lr_final": 0.1}
    trainer = train_prior(cache, out, PriorTrainConfig(**schedule), max_minutes=5, max_steps=6, explicit=schedule,
                          progress=False)
    assert trainer.step == 6 and trainer.config.lr == 5e-4 and trainer.config.decay_start == 6
    assert trainer.opt.param_groups[0]["lr"] == pytest.approx(5e-4)


def test_derived_positions_are_what_the_rotation_channels_place_and_a_stage_may_turn_them_on(tmp_path):
    from motioncore.representation import FEATURES, positions_from_rotations
    from transfer.denoiser import Denoiser, DenoiserConfig

    g = torch.Generator().manual_seed(0)
    mean, std = torch.randn(FEATURES.dim, generator=g) * 0.1, torch.rand(FEATURES.dim, generator=g) + 0.5
    model = Denoiser(DenoiserConfig(width=32, layers=1, heads=2, ff=64, dropout=0.0, derive_positions=True)).eval()
    x, t = torch.randn(2, 12, FEATURES.dim, generator=g), torch.tensor([10, 500])
    with pytest.raises(RuntimeError, match="set_normalization"):
        model(x, t)
    out = model.set_normalization(mean, std)(x, t)
    raw = out * std + mean
    implied = positions_from_rotations(raw).flatten(-2)
    assert torch.allclose(raw[..., FEATURES.positions], implied, atol=1e-5)  # the two channel sets agree
    # a finished run may resume as a new stage with derived positions; the exported prior loads with them
    cache, out_dir = _cache(tmp_path), tmp_path / "run"
    train_prior(cache, out_dir, PriorTrainConfig(**TINY), max_minutes=5, max_steps=2, explicit=dict(TINY), progress=False)
    stage = {"derive_positions": True}
    trainer = train_prior(cache, out_dir, PriorTrainConfig(**stage), max_minutes=5, max_steps=4, explicit=stage,
                          progress=False)
    assert trainer.step == 4 and trainer.model.config.derive_positions and trainer.ema.normalization_set
    prior, p_mean, p_std = load_prior(out_dir / "denoiser.safetensors")
    assert prior.config.derive_positions and prior.normalization_set
    y = prior(torch.randn(1, 24, FEATURES.dim), torch.tensor([100]))
    assert torch.allclose((y * p_std + p_mean)[..., FEATURES.positions],
                          positions_from_rotations(y * p_std + p_mean).flatten(-2), atol=1e-5)
