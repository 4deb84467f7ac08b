"""Long takes keep apply's memory down (issue 25): windows are cut from the clip a batch at a time and blended
in as they come, never all held at once. The results are the same, bit for bit, as the whole-list path
(every window cut first, every result kept, then blended) written out here."""

from __future__ import annotations

import pytest
import torch

import transfer.apply as apply_mod
from mlcore.windows import crossfade, window_starts
from motioncore.representation import FEATURES
from tests.helpers import tiny_denoiser, trained_style
from transfer.bundle import MethodBundle
from transfer.edit import neutralize, stylize
from transfer.scheduler import DiffusionScheduler
from transfer.style_config import ApplyConfig, LearnConfig, strength_settings
from transfer.style_file import style_model


def blend_whole_list(chunks: list[torch.Tensor], starts: list[int], n: int) -> torch.Tensor:
    """The blend as it was before: every window's result in one list, then an out-of-place division."""
    out, total, prev_end = torch.zeros(n, chunks[0].shape[-1]), torch.zeros(n, 1), 0
    for chunk, s in zip(chunks, starts):
        w = torch.ones(chunk.shape[0])
        if s > 0:
            ramp = max(1, prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2)[1:-1]
        out[s:s + chunk.shape[0]] += chunk * w[:, None]
        total[s:s + chunk.shape[0]] += w[:, None]
        prev_end = max(prev_end, s + chunk.shape[0])
    return out / total.clamp_min(1e-6)


def whole_list_apply(model, prior, x, learned, config, step, seed, neutral_text=None, batch=2, window=80, overlap=20):
    """apply_style_features the whole-list way: all windows copied up front, all results kept."""
    scheduler = DiffusionScheduler(model.config.num_train_steps)
    starts = window_starts(x.shape[0], window, overlap)

    def all_windows(v):
        return v.unfold(0, min(window, v.shape[0]), 1)[starts].transpose(1, 2)

    if neutral_text is not None:
        parts, gen, text = all_windows(x), torch.Generator().manual_seed(seed + 1), neutral_text.expand(len(starts), -1)
        done = []
        for i in range(0, len(starts), batch):
            done.extend(neutralize(prior, scheduler, parts[i:i + batch], text[i:i + batch], learned, gen,
                                   config.neutralize_step))
        x = blend_whole_list(done, starts, x.shape[0])
    parts, gen, done = all_windows(x), torch.Generator().manual_seed(seed), []
    for i in range(0, len(starts), batch):
        done.extend(stylize(model, scheduler, parts[i:i + batch], learned, config, gen, step=step, prior=prior))
    return blend_whole_list(done, starts, x.shape[0])


@pytest.mark.slow
@pytest.mark.parametrize("frames", [50, 80, 401])
@pytest.mark.parametrize("mode", ["difference", "regenerate"])
def test_streamed_windows_give_the_whole_list_result(monkeypatch, frames, mode):
    monkeypatch.setattr(apply_mod, "WINDOW_BATCH", 2)  # 401 frames: 7 windows in 4 batches
    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    x = torch.randn(frames, FEATURES.dim, generator=torch.Generator().manual_seed(frames))
    learned, config = LearnConfig(), ApplyConfig(apply_mode=mode, neutralize_step=200)
    text = torch.randn(1, 384, generator=torch.Generator().manual_seed(1))
    for neutral in (None, text):
        got = apply_mod.apply_style_features(MethodBundle(prior), model, x.clone(), learned, config, None, 3, neutral)
        # the style's own setting (None) is the default strength: its scale as strength_settings makes it
        want = whole_list_apply(model, prior, x.clone(), learned, strength_settings(None, learned, config)[1], 300, 3,
                                neutral)
        assert torch.equal(got, want)


def test_crossfade_takes_windows_as_they_come():
    n, starts = 333, window_starts(333, 80, 20)
    values = torch.randn(n, 5)
    windows = [values[s:s + 80] * (1 + s) for s in starts]
    assert torch.equal(crossfade(iter(windows), starts, n), blend_whole_list(windows, starts, n))
    assert torch.equal(crossfade(windows, starts, n), blend_whole_list(windows, starts, n))
    with pytest.raises(ValueError, match="expected at least one window"):
        crossfade(iter([]), [], 10)


@pytest.mark.parametrize("pieces", [[333], [1, 79, 100, 153], [40] * 8 + [13], [200, 0, 133]])
def test_window_stream_fed_in_pieces_blends_as_crossfade(pieces):
    from mlcore.windows import WindowStream

    n, starts = 333, window_starts(333, 80, 20)
    values = torch.randn(n, 5, generator=torch.Generator().manual_seed(4))
    seen = []

    def fn(batch, i):
        seen.append((i, batch.shape[0]))
        return [w * (1 + s) for w, s in zip(batch, starts[i:])]

    stream, a, out = WindowStream(fn, n, 2), 0, []
    for k in pieces:
        out.append(stream.feed(values[a:a + k]))
        a += k
    want = crossfade([values[s:s + 80] * (1 + s) for s in starts], starts, n)
    assert torch.equal(torch.cat(out), want)
    assert seen == [(i, min(2, len(starts) - i)) for i in range(0, len(starts), 2)]  # the whole clip's batches


def fit_inputs(frames: int = 23):
    """Targets (T, J, 3) from a random canonical motion, and a head rotation per frame (a leaf rotation)."""
    from motioncore.skeleton import CANONICAL
    from testkit.motions import random_motion

    motion = random_motion(frames / 20.0, 20.0, seed=5)
    head = motion.lrot[:, CANONICAL.skeleton.index("Head")]
    return motion.global_positions(), {CANONICAL.skeleton.index("Head"): head}


@pytest.mark.parametrize("chunk", [1, 2, 7])
def test_fit_positions_a_chunk_at_a_time_gives_the_whole_clip_result(monkeypatch, chunk):
    """The position fit (decode_guarded's largest memory cost on a long take) solves frames a chunk at a time; a
    quaternion's sign stays continuous across chunks (unrolled over the whole clip)."""
    import motioncore.ik_fit as ik

    targets, leaves = fit_inputs()
    whole = ik.fit_positions(targets, 20.0, leaf_rotations=leaves)
    assert whole.num_frames == 23 and whole.lrot.dtype == whole.lpos.dtype == torch.float32
    monkeypatch.setattr(ik, "CHUNK", chunk)
    parts = ik.fit_positions(targets, 20.0, leaf_rotations=leaves)
    # equal but for the last bit of components near zero (~1e-17: double-precision vector maths rounds a frame by
    # where it falls in a SIMD lane); a sign flip lost between chunks, or a frame solved twice, would be O(1)
    torch.testing.assert_close(parts.lrot, whole.lrot, atol=1e-12, rtol=0)
    assert torch.equal(parts.lpos, whole.lpos)
    flipped = ik.fit_positions(targets, 20.0, relative=False, hinges={})
    monkeypatch.setattr(ik, "CHUNK", 5_000)
    torch.testing.assert_close(flipped.lrot, ik.fit_positions(targets, 20.0, relative=False, hinges={}).lrot,
                               atol=1e-12, rtol=0)


@pytest.mark.parametrize("chunk", [1, 7, 5_000])
def test_decode_positions_of_a_long_take_needs_no_float64_copy_and_gives_the_same_values(monkeypatch, chunk):
    """The position decode (inside the guarded decode) places joints a chunk at a time from float32 features; the
    root path is integrated over the whole clip, so every value is the one the float64 copy gave."""
    import motioncore.representation as rep

    feats = torch.randn(40, FEATURES.dim, generator=torch.Generator().manual_seed(2))
    want = rep.decode_positions(feats.double(), start_yaw=0.3)
    monkeypatch.setattr(rep, "CHUNK", chunk)
    got = rep.decode_positions(feats, start_yaw=0.3, dtype=torch.float64)
    assert got.dtype == torch.float64 and torch.equal(got, want)
    assert torch.equal(rep.decode_positions(feats, start_yaw=0.3), rep.decode_positions(feats[None], start_yaw=0.3)[0])
    grad = feats.clone().requires_grad_(True)  # training's path keeps its gradient (whole clip)
    rep.decode_positions(grad).sum().backward()
    assert grad.grad is not None and torch.isfinite(grad.grad).all()
