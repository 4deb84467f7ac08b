"""The content keeper at apply (transfer.apply.keep_content): a style's change is scaled down only as far as the
motion encoder needs to read the content's action again, and a clip the encoder does not know is left alone."""
import pytest
import torch
import torch.nn.functional as F

from mlcore.captions import BANDAI2_CONTENTS, STYLES, caption
from motioncore.representation import FEATURES
from transfer.apply import CONTENT_KEEP_SHARES, content_probabilities, keep_content

N_CONTENTS = len(BANDAI2_CONTENTS)


class _Text:
    """Every caption of content c embeds as the c-th unit vector (one spare dimension for foreign clips)."""

    def encode(self, texts):
        index = {caption(c, s): i for i, c in enumerate(BANDAI2_CONTENTS) for s in STYLES}
        return torch.eye(N_CONTENTS + 1)[[index[t] for t in texts]]


class _Encoder(torch.nn.Module):
    """Reads content 0 where channel ``ch`` is low, content 1 where it is high; channel ``ch + 1`` points away from
    every caption."""

    def __init__(self, ch: int = 0):
        super().__init__()
        self.ch = ch

    def forward(self, x):  # (N, L, D) -> (N, E)
        m = torch.sigmoid(4 * x[..., self.ch].mean(-1))
        z = torch.zeros(x.shape[0], N_CONTENTS + 1)
        z[:, 0], z[:, 1], z[:, -1] = 1 - m, m, x[..., self.ch + 1].mean(-1).abs()
        return F.normalize(z, dim=-1)


def _clip(channel0: float, channel1: float = 0.0, frames: int = 200) -> torch.Tensor:
    x = torch.zeros(frames, FEATURES.dim)
    x[:, 0], x[:, 1] = channel0, channel1
    return x


def test_the_encoder_reads_the_toy_contents():
    p = content_probabilities(_Encoder(), _Text(), _clip(-2.0))
    assert p.shape == (N_CONTENTS,) and p.argmax() == 0 and p[0] > 0.9
    assert content_probabilities(_Encoder(), _Text(), _clip(2.0)).argmax() == 1


def test_a_change_that_keeps_the_action_is_left_whole():
    content, out = _clip(-2.0), _clip(-1.5)
    kept, share = keep_content(_Encoder(), _Text(), out, content, 0.8)
    assert share == 1.0 and torch.equal(kept, out)


def test_a_change_that_loses_the_action_is_scaled_down_to_the_largest_share_that_keeps_it():
    content, out = _clip(-2.0), _clip(2.0)  # the change turns the action into content 1
    kept, share = keep_content(_Encoder(), _Text(), out, content, 0.8)
    assert share in CONTENT_KEEP_SHARES and share < 1
    assert torch.allclose(kept, content + share * (out - content))
    p0 = content_probabilities(_Encoder(), _Text(), content)[0]
    assert content_probabilities(_Encoder(), _Text(), kept)[0] >= 0.8 * p0
    larger = [s for s in (1.0, *CONTENT_KEEP_SHARES) if s > share]
    for s in larger:  # every larger share loses it
        assert content_probabilities(_Encoder(), _Text(), content + s * (out - content))[0] < 0.8 * p0


def test_a_clip_the_encoder_does_not_know_is_left_alone():
    content, out = _clip(-2.0, channel1=5.0), _clip(2.0, channel1=5.0)  # far from every caption: not confident
    kept, share = keep_content(_Encoder(), _Text(), out, content, 0.8)
    assert share == 1.0 and torch.equal(kept, out)


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="expected out and content alike"):
        keep_content(_Encoder(), _Text(), _clip(0.0, frames=10), _clip(0.0), 0.5)
    with pytest.raises(ValueError, match="expected keep in"):
        keep_content(_Encoder(), _Text(), _clip(0.0), _clip(0.0), 0.0)
    with pytest.raises(ValueError, match="expected features"):
        content_probabilities(_Encoder(), _Text(), torch.zeros(10, 3))


def test_apply_keeps_the_content_only_when_the_config_says_so_and_reports_the_share():
    from dataclasses import replace

    from tests.helpers import tiny_denoiser, trained_style
    from transfer.apply import apply_style_features
    from transfer.bundle import MethodBundle
    from transfer.style_config import ApplyConfig, LearnConfig
    from transfer.style_file import style_model

    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    encoder = _Encoder(ch=FEATURES.positions.start)  # a channel the style changes (the root's path is kept)
    bundle = MethodBundle(prior, motion_encoder=encoder, text_encoder=_Text())
    torch.manual_seed(0)
    x = torch.randn(90, FEATURES.dim) * 0.1
    x[:, FEATURES.positions.start] = -0.5
    learned, config = LearnConfig(), ApplyConfig(style_scale=20.0, content_keep=0.0)
    report: dict = {}  # off: no share reported (the still-pose guard reports its own)
    plain = apply_style_features(bundle, model, x, learned, config, report=report)
    assert "content_share" not in report and 0 <= report["still_share"] <= 1
    kept = apply_style_features(bundle, model, x, learned, replace(config, content_keep=0.9), report=report)
    expected, share = keep_content(encoder, _Text(), plain, x, 0.9)
    assert torch.allclose(kept, expected, atol=1e-6) and report["content_share"] == share and share < 1


def test_with_top_a_result_still_read_first_as_the_content_s_action_passes():
    content, out = _clip(-2.0), _clip(-0.01)  # the action still read first, but much less surely
    p = content_probabilities(_Encoder(), _Text(), out)
    assert p.argmax() == 0 and p[0] < 0.8 * content_probabilities(_Encoder(), _Text(), content)[0]
    assert keep_content(_Encoder(), _Text(), out, content, 0.8)[1] < 1
    kept, share = keep_content(_Encoder(), _Text(), out, content, 0.8, top=True)
    assert share == 1.0 and torch.equal(kept, out)


def test_apply_holds_the_arms_of_a_clip_done_in_place_under_a_travelling_examples_style():
    from dataclasses import replace

    from tests.helpers import tiny_denoiser, trained_style
    from transfer.apply import apply_style_features
    from transfer.bundle import MethodBundle
    from transfer.posture import keep_arm_motion
    from transfer.style_config import ApplyConfig, LearnConfig
    from transfer.style_file import style_model

    prior = tiny_denoiser()
    model = style_model(prior, trained_style(prior))
    bundle = MethodBundle(prior, mean=torch.zeros(FEATURES.dim), std=torch.ones(FEATURES.dim))
    torch.manual_seed(0)
    x = torch.randn(90, FEATURES.dim) * 0.1
    x[:, FEATURES.root_lvel] = torch.tensor([0.0, 0.001])  # 2 cm/s: in place
    example = x.clone()
    example[:, FEATURES.root_lvel] = torch.tensor([0.0, 0.06])  # 1.2 m/s: a walk
    learned, config = LearnConfig(), ApplyConfig(style_scale=20.0, content_keep=0.0, posture=0.0)
    report: dict = {}
    plain = apply_style_features(bundle, model, x, learned, replace(config, arm_travel=0.0), report=report)
    assert "arm_motion_share" not in report
    held = apply_style_features(bundle, model, x, learned, config, example=example, report=report)
    assert report["arm_motion_share"] == pytest.approx(0.02 / 0.6, rel=1e-3)
    assert torch.allclose(held, keep_arm_motion(plain, x, report["arm_motion_share"]), atol=1e-5)
    assert not torch.allclose(held, plain, atol=1e-3)
