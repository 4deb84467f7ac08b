import pytest
import torch

from motioncore import quat
from motioncore.motion import mirror, resample
from motioncore.representation import (
    FEATURES,
    decode,
    decode_positions,
    encode,
    facing_angle,
    foot_contacts,
)
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion


def _start(m):
    p = m.global_positions()
    return facing_angle(p[0:1].double())[0].item(), (p[0, 0, 0].item(), p[0, 0, 2].item())


def test_layout_is_consistent():
    j = CANONICAL.num_joints
    assert FEATURES.dim == 4 + 3 * (j - 1) + 6 * j + 4
    assert FEATURES.contacts.stop == FEATURES.dim


def test_round_trip_10s_within_1mm():
    m = random_motion(seconds=10.0, seed=3)
    yaw, xz = _start(m)
    back = decode(encode(m), start_yaw=yaw, start_xz=xz)
    err = (back.global_positions() - m.global_positions()).norm(dim=-1)
    assert err.max() < 1e-3


def test_position_features_decode_to_same_positions():
    m = random_motion(seconds=4.0, seed=4)
    yaw, xz = _start(m)
    pos = decode_positions(encode(m), start_yaw=yaw) + torch.tensor([xz[0], 0.0, xz[1]])
    assert (pos - m.global_positions()).norm(dim=-1).max() < 1e-3


def test_features_are_heading_invariant():
    m = random_motion(seconds=3.0, seed=5)
    turned = m.lrot.clone()
    turned[:, 0] = quat.mul(quat.from_yaw(torch.tensor(1.0)).expand(m.num_frames, 4), m.lrot[:, 0])
    lpos = m.lpos.clone()
    lpos[:, 0] = quat.mul_vec(quat.from_yaw(torch.tensor(1.0)).expand(m.num_frames, 4), m.lpos[:, 0])
    f1, f2 = encode(m), encode(type(m)(m.skeleton, turned, lpos, m.fps))
    assert torch.allclose(f1, f2, atol=1e-4)


def test_contacts_flag_a_planted_foot():
    m = random_motion(seconds=2.0, seed=6, amplitude=0.0)  # rest pose sliding at 1.2 m/s
    gpos = m.global_positions()
    assert foot_contacts(gpos, m.fps).sum() == 0  # moving: no contact
    still = type(m)(m.skeleton, m.lrot, m.lpos[:1].expand_as(m.lpos).clone(), m.fps)
    assert foot_contacts(still.global_positions(), m.fps).all()


def test_mirror_is_an_involution_and_reflects_positions():
    m = random_motion(seconds=2.0, seed=7)
    mm = mirror(m)
    assert torch.allclose(mirror(mm).lrot, m.lrot) and torch.allclose(mirror(mm).lpos, m.lpos)
    p, pm = m.global_positions(), mm.global_positions()
    expected = p[:, list(CANONICAL.mirror)] * torch.tensor([-1.0, 1.0, 1.0])
    assert (pm - expected).abs().max() < 1e-5


def test_resample_keeps_duration_and_endpoints():
    m = random_motion(seconds=3.0, fps=30.0, seed=8)
    r = resample(m, 20.0)
    assert r.num_frames == 60 and r.fps == 20.0
    assert torch.allclose(r.lpos[0], m.lpos[0]) and torch.allclose(r.lrot[0], m.lrot[0], atol=1e-6)


@pytest.mark.slow
def test_encode_and_decode_a_chunk_at_a_time_give_the_same_numbers(monkeypatch):
    import motioncore.representation as rep
    from testkit.motions import random_motion

    m = random_motion(seconds=6.0, seed=3)
    f, d = rep.encode(m), rep.decode(rep.encode(m))
    for chunk in (7, 2, 1):
        monkeypatch.setattr(rep, "CHUNK", chunk)
        assert torch.equal(rep.encode(m), f) and torch.equal(rep.decode(f).lrot, d.lrot)
