import torch

from transfer.sampling import denoise, overwrite
from transfer.scheduler import DiffusionScheduler


class Oracle(torch.nn.Module):
    """A toy denoiser that always predicts the same clean motion."""

    def __init__(self, target):
        super().__init__()
        self.target = target

    def forward(self, x_t, t, text=None, valid=None):
        return self.target.expand_as(x_t)


def test_schedule_is_monotone_and_ends_near_pure_noise():
    s = DiffusionScheduler(1000)
    a = s.alphas_cumprod
    assert a.shape == (1000,) and (a[1:] <= a[:-1]).all()
    assert a[0] > 0.999 and a[-1] < 1e-3


def test_set_timesteps_from_any_start():
    s = DiffusionScheduler(1000)
    steps = s.set_timesteps(6, start=300)
    assert steps[0] == 300 and steps[-1] == 0 and len(steps) == 6
    assert s.previous(300) == int(steps[1]) and s.previous(0) == -1


def test_add_noise_statistics():
    s = DiffusionScheduler(1000)
    g = torch.Generator().manual_seed(0)
    x0 = torch.full((2000, 1, 1), 2.0)
    xt = s.add_noise(x0, torch.randn(x0.shape, generator=g), 500)
    a = s.alphas_cumprod[500]
    assert abs(xt.mean() - 2.0 * a.sqrt()) < 0.05 and abs(xt.std() - (1 - a).sqrt()) < 0.05


def test_ddim_with_oracle_recovers_target_exactly():
    s = DiffusionScheduler(1000)
    g = torch.Generator().manual_seed(1)
    target = torch.randn(1, 10, 4, generator=g)
    x = torch.randn(3, 10, 4, generator=g)
    out = denoise(Oracle(target), s, x, 999, 20)
    assert torch.allclose(out, target.expand_as(out), atol=1e-5)


def test_inpainting_keeps_reference_slices_and_zero_noise():
    s = DiffusionScheduler(1000)
    g = torch.Generator().manual_seed(2)
    target = torch.zeros(1, 8, 5)
    ref = torch.randn(1, 8, 5, generator=g)
    seen = []

    class Spy(Oracle):
        def forward(self, x_t, t, text=None, valid=None):
            seen.append((int(t[0]), x_t[..., 1:3].clone()))
            return super().forward(x_t, t, text, valid)

    x = s.add_noise(torch.zeros(1, 8, 5), torch.randn(1, 8, 5, generator=g), 300)
    x = overwrite(x, ref * s.alphas_cumprod[300].sqrt(), [slice(1, 3)])
    out = denoise(Spy(target), s, x, 300, 6, inpaint=(ref, [slice(1, 3)]))
    assert torch.allclose(out[..., 1:3], ref[..., 1:3], atol=1e-6)  # inpainted slices = reference
    assert torch.allclose(out[..., 3:], target[..., 3:].expand(1, 8, 2), atol=1e-5)
    for t, xs in seen:  # the noisy input carries the reference on those slices, without noise
        assert torch.allclose(xs, ref[..., 1:3] * s.alphas_cumprod[t].sqrt(), atol=1e-5)


def test_ddpm_eta_is_seeded():
    s = DiffusionScheduler(1000)
    target = torch.ones(1, 4, 2)
    a = denoise(Oracle(target), s, torch.zeros(1, 4, 2), 500, 5, eta=1.0, generator=torch.Generator().manual_seed(3))
    b = denoise(Oracle(target), s, torch.zeros(1, 4, 2), 500, 5, eta=1.0, generator=torch.Generator().manual_seed(3))
    assert torch.equal(a, b)


def test_a_guide_corrects_every_x0_prediction_and_the_last_one_is_the_result():
    model = Oracle(torch.zeros(1, 6, 3))
    seen = []

    def guide(x0):
        seen.append(x0.clone())
        return x0 + 1.0

    out = denoise(model, DiffusionScheduler(100), torch.randn(1, 6, 3), 99, 5, guide=guide)
    assert len(seen) == 5 and torch.allclose(out, torch.ones(1, 6, 3))
