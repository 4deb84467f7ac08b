import math

import pytest
import torch

from motioncore import quat
from motioncore.kinematics import fk

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]


def test_wxyz_convention_and_known_rotation():
    q = quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), torch.tensor(math.pi / 2))
    assert torch.allclose(q, torch.tensor([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)]))
    assert torch.allclose(quat.mul_vec(q, torch.tensor([1.0, 0.0, 0.0])), torch.tensor([0.0, 1.0, 0.0]), atol=1e-6)


def test_yaw_maps_forward_z():
    a = torch.tensor(0.3)
    v = quat.mul_vec(quat.from_yaw(a), torch.tensor([0.0, 0.0, 1.0]))
    assert torch.allclose(v, torch.tensor([math.sin(0.3), 0.0, math.cos(0.3)]), atol=1e-6)


def test_euler_order_is_bvh_matrix_product():
    # "ZXY" means R = Rz(a) @ Rx(b) @ Ry(c)
    a, b, c = 0.3, -0.5, 1.1
    q = quat.from_euler(torch.tensor([a, b, c]), "ZXY")
    rz = quat.to_matrix(quat.from_axis_angle(torch.tensor([0.0, 0, 1]), torch.tensor(a)))
    rx = quat.to_matrix(quat.from_axis_angle(torch.tensor([1.0, 0, 0]), torch.tensor(b)))
    ry = quat.to_matrix(quat.from_axis_angle(torch.tensor([0.0, 1, 0]), torch.tensor(c)))
    assert torch.allclose(quat.to_matrix(q), rz @ rx @ ry, atol=1e-6)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_round_trip(order):
    g = torch.Generator().manual_seed(1)
    angles = (torch.rand(500, 3, generator=g, dtype=torch.float64) - 0.5) * torch.tensor([2 * math.pi, math.pi * 0.999, 2 * math.pi], dtype=torch.float64)
    q = quat.from_euler(angles, order)
    back = quat.to_euler(q, order)
    q2 = quat.from_euler(back, order)
    assert ((q * q2).sum(-1).abs() > 1 - 1e-10).all()


def test_euler_gimbal_lock_still_same_rotation():
    q = quat.from_euler(torch.tensor([0.4, math.pi / 2, -0.2], dtype=torch.float64), "ZXY")
    q2 = quat.from_euler(quat.to_euler(q, "ZXY"), "ZXY")
    assert (q * q2).sum().abs() > 1 - 1e-9


def test_matrix_and_6d_round_trip_over_leading_dims():
    q = quat.normalize(torch.randn(4, 5, 7, 4, generator=torch.Generator().manual_seed(0)))
    q = torch.where(q[..., :1] < 0, -q, q)
    assert torch.allclose(quat.from_matrix(quat.to_matrix(q)), q, atol=1e-5)
    assert torch.allclose(quat.from_6d(quat.to_6d(q)), q, atol=1e-5)


def test_between_and_fit_rotation():
    u, v = torch.tensor([1.0, 0.0, 0.0]), torch.tensor([0.0, 0.0, -1.0])
    assert torch.allclose(quat.mul_vec(quat.between(u, v), u), v, atol=1e-6)
    assert torch.allclose(quat.mul_vec(quat.between(u, -u), u), -u, atol=1e-6)
    r = quat.normalize(torch.tensor([0.8, 0.1, -0.4, 0.3]))
    src = torch.randn(6, 3, generator=torch.Generator().manual_seed(2))
    fitted = quat.fit_rotation(src, quat.mul_vec(r, src))
    assert (fitted * r).sum().abs() > 1 - 1e-6


def test_slerp_endpoints_and_midpoint():
    a = quat.identity()
    b = quat.from_axis_angle(torch.tensor([0.0, 1.0, 0.0]), torch.tensor(1.0))
    assert torch.allclose(quat.slerp(a, b, 0.0), a, atol=1e-6)
    assert torch.allclose(quat.slerp(a, b, 1.0), b, atol=1e-6)
    assert torch.allclose(quat.angle(quat.slerp(a, b, 0.5)), torch.tensor(0.5), atol=1e-6)


def test_bad_shapes_raise_expected_got():
    with pytest.raises(ValueError, match="expected shape"):
        quat.mul(torch.zeros(3), torch.zeros(4))
    with pytest.raises(ValueError, match="expected"):
        fk(torch.zeros(2, 3, 4), torch.zeros(2, 2, 3), [-1, 0, 1])


def test_fk_known_chain():
    parents = [-1, 0, 1]
    lrot = quat.identity(3)
    lrot[1] = quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), torch.tensor(math.pi / 2))
    lpos = torch.tensor([[1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0]])
    _, gpos = fk(lrot, lpos, parents)
    assert torch.allclose(gpos, torch.tensor([[1.0, 0, 0], [1.0, 1.0, 0], [1.0, 2.0, 0]]), atol=1e-6)
