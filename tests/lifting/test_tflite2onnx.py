"""The TFLite → ONNX converter, op by op against numpy references, then whole models.

One-op graphs are built directly as :class:`Graph` objects (the converter's
input), converted, and run with onnxruntime. The references below follow
TensorFlow/TFLite semantics (SAME padding, NHWC, TFLite's bilinear kernel),
written independently of the converter.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lifting.blazepose.sparse import densify, dequantize
from lifting.blazepose.tflite2onnx import graph_to_onnx
from lifting.blazepose.tflite_model import (
    DimMetadata,
    Graph,
    Op,
    Quantization,
    Sparsity,
    Tensor,
)

DATA = Path(__file__).parent / "data"
RNG = np.random.default_rng(1234)


# -- helpers -------------------------------------------------------------------
def act(name: str, shape, dtype=np.float32) -> Tensor:
    return Tensor(name, tuple(shape), dtype)


def const(name: str, data: np.ndarray, **kw) -> Tensor:
    return Tensor(name, tuple(data.shape), data.dtype.type, data=data, **kw)


def run(
    tensors: list[Tensor], ops: list[Op], inputs: list[int], outputs: list[int], *feeds: np.ndarray
) -> list[np.ndarray]:
    model = graph_to_onnx(Graph(tensors, ops, inputs, outputs))
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    names = [tensors[i].name for i in inputs]
    return session.run(None, dict(zip(names, feeds)))


def run_op(kind: str, x: np.ndarray, consts: list[np.ndarray], out_shape, options: dict) -> np.ndarray:
    """One op: graph input x, then constant inputs, one output."""
    tensors = [act("x", x.shape, x.dtype.type)] + [const(f"c{i}", c) for i, c in enumerate(consts)]
    tensors.append(act("y", out_shape))
    op = Op(kind, list(range(len(tensors) - 1)), [len(tensors) - 1], options)
    return run(tensors, [op], [0], [len(tensors) - 1], x)[0]


def tf_same_pads(size: int, k: int, s: int, d: int = 1) -> tuple[int, int, int]:
    """(output size, pad before, pad after) of TensorFlow SAME padding."""
    out = math.ceil(size / s)
    total = max((out - 1) * s + (k - 1) * d + 1 - size, 0)
    return out, total // 2, total - total // 2


def windows(x: np.ndarray, kh: int, kw: int, stride, dilation, padding, fill=0.0) -> np.ndarray:
    """NHWC x → (N, OH, OW, KH, KW, C) patches with TF padding."""
    n, h, w, c = x.shape
    if padding == "SAME":
        oh, t, b = tf_same_pads(h, kh, stride[0], dilation[0])
        ow, l, r = tf_same_pads(w, kw, stride[1], dilation[1])
        x = np.pad(x, ((0, 0), (t, b), (l, r), (0, 0)), constant_values=fill)
    else:
        oh = (h - (kh - 1) * dilation[0] - 1) // stride[0] + 1
        ow = (w - (kw - 1) * dilation[1] - 1) // stride[1] + 1
    out = np.empty((n, oh, ow, kh, kw, c), x.dtype)
    for i in range(kh):
        for j in range(kw):
            r0, c0 = i * dilation[0], j * dilation[1]
            out[:, :, :, i, j] = x[
                :, r0 : r0 + (oh - 1) * stride[0] + 1 : stride[0], c0 : c0 + (ow - 1) * stride[1] + 1 : stride[1]
            ]
    return out


def conv_ref(x, w, b, stride, padding, dilation=(1, 1), activation="NONE"):
    """TF conv2d: x NHWC, w (O,KH,KW,I)."""
    p = windows(x.astype(np.float64), w.shape[1], w.shape[2], stride, dilation, padding)
    y = np.einsum("nhwijc,oijc->nhwo", p, w.astype(np.float64)) + b
    return np.clip(y, 0, 6) if activation == "RELU6" else y


def depthwise_ref(x, w, b, stride, padding, multiplier, dilation=(1, 1)):
    """TF depthwise conv: w (1,KH,KW,C*M), output channel c*M+m."""
    p = windows(x.astype(np.float64), w.shape[1], w.shape[2], stride, dilation, padding)
    c = x.shape[3]
    wk = w[0].reshape(w.shape[1], w.shape[2], c, multiplier).astype(np.float64)
    y = np.einsum("nhwijc,ijcm->nhwcm", p, wk)
    return y.reshape(*y.shape[:3], c * multiplier) + b


def resize_bilinear_ref(x, out_h, out_w, align_corners, half_pixel):
    """Port of TFLite's reference_ops::ResizeBilinear (float)."""
    n, h, w, c = x.shape

    def scale(i, o):
        return (i - 1) / (o - 1) if align_corners and o > 1 else i / o

    sy, sx = scale(h, out_h), scale(w, out_w)
    y = np.zeros((n, out_h, out_w, c))
    for oy in range(out_h):
        iy = (oy + 0.5) * sy - 0.5 if half_pixel else oy * sy
        y0, y1 = max(math.floor(iy), 0), min(math.ceil(iy), h - 1)
        for ox in range(out_w):
            ix = (ox + 0.5) * sx - 0.5 if half_pixel else ox * sx
            x0, x1 = max(math.floor(ix), 0), min(math.ceil(ix), w - 1)
            fy, fx = iy - math.floor(iy), ix - math.floor(ix)
            y[:, oy, ox] = (
                x[:, y0, x0] * (1 - fy) * (1 - fx)
                + x[:, y1, x0] * fy * (1 - fx)
                + x[:, y0, x1] * (1 - fy) * fx
                + x[:, y1, x1] * fy * fx
            )
    return y


def randn(*shape) -> np.ndarray:
    return RNG.standard_normal(shape).astype(np.float32)


# -- convolutions ----------------------------------------------------------------
@pytest.mark.parametrize("padding", ["SAME", "VALID"])
@pytest.mark.parametrize("stride", [(1, 1), (2, 2), (2, 1)])
@pytest.mark.parametrize("size,kernel", [((7, 8), (3, 3)), ((6, 5), (1, 1)), ((9, 9), (5, 3))])
def test_conv_2d(padding, stride, size, kernel):
    x, w, b = randn(1, *size, 3), randn(4, *kernel, 3), randn(4)
    expected = conv_ref(x, w, b, stride, padding, activation="RELU6")
    options = {"padding": padding, "stride": stride, "dilation": (1, 1), "activation": "RELU6"}
    got = run_op("CONV_2D", x, [w, b], expected.shape, options)
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, atol=1e-4)


def test_conv_2d_dilation_and_no_bias():
    x, w = randn(1, 10, 9, 2), randn(3, 3, 3, 2)
    expected = conv_ref(x, w, 0.0, (1, 1), "SAME", dilation=(2, 2))
    tensors = [act("x", x.shape), const("w", w), act("y", expected.shape)]
    options = {"padding": "SAME", "stride": (1, 1), "dilation": (2, 2), "activation": "NONE"}
    got = run(tensors, [Op("CONV_2D", [0, 1, -1], [2], options)], [0], [2], x)[0]
    np.testing.assert_allclose(got, expected, atol=1e-4)


@pytest.mark.parametrize("padding", ["SAME", "VALID"])
@pytest.mark.parametrize("stride", [(1, 1), (2, 2)])
@pytest.mark.parametrize("multiplier", [1, 2])
def test_depthwise_conv_2d(padding, stride, multiplier):
    x, w, b = randn(1, 9, 8, 3), randn(1, 3, 3, 3 * multiplier), randn(3 * multiplier)
    expected = depthwise_ref(x, w, b, stride, padding, multiplier)
    options = {
        "padding": padding,
        "stride": stride,
        "dilation": (1, 1),
        "activation": "NONE",
        "depth_multiplier": multiplier,
    }
    got = run_op("DEPTHWISE_CONV_2D", x, [w, b], expected.shape, options)
    np.testing.assert_allclose(got, expected, atol=1e-4)


# -- pooling, padding, resampling ---------------------------------------------------
@pytest.mark.parametrize("padding,size", [("SAME", (8, 8)), ("SAME", (7, 5)), ("VALID", (7, 6))])
def test_max_pool_2d(padding, size):
    x = randn(1, *size, 4) - 3.0  # all negative: a zero-padded max would show
    expected = windows(x, 2, 2, (2, 2), (1, 1), padding, fill=-np.inf).max(axis=(3, 4))
    options = {"padding": padding, "stride": (2, 2), "filter": (2, 2), "activation": "NONE"}
    got = run_op("MAX_POOL_2D", x, [], expected.shape, options)
    np.testing.assert_allclose(got, expected, atol=1e-6)


def test_pad_4d_and_2d():
    x = randn(1, 4, 5, 3)
    paddings = np.array([[0, 0], [1, 2], [0, 1], [2, 0]], np.int32)
    expected = np.pad(x, paddings)
    np.testing.assert_array_equal(run_op("PAD", x, [paddings], expected.shape, {}), expected)
    x2, p2 = randn(3, 4), np.array([[1, 0], [2, 3]], np.int32)
    np.testing.assert_array_equal(run_op("PAD", x2, [p2], np.pad(x2, p2).shape, {}), np.pad(x2, p2))


@pytest.mark.parametrize(
    "align_corners,half_pixel",
    [(False, True), (True, False), (False, False)],
    ids=["half_pixel", "align_corners", "asymmetric"],
)
@pytest.mark.parametrize("in_size,out_size", [((4, 5), (8, 10)), ((5, 7), (7, 3)), ((3, 3), (7, 5))])
def test_resize_bilinear(align_corners, half_pixel, in_size, out_size):
    x = randn(1, *in_size, 2)
    expected = resize_bilinear_ref(x.astype(np.float64), *out_size, align_corners, half_pixel)
    options = {"align_corners": align_corners, "half_pixel_centers": half_pixel}
    got = run_op("RESIZE_BILINEAR", x, [np.array(out_size, np.int32)], expected.shape, options)
    np.testing.assert_allclose(got, expected, atol=1e-5)


def test_depth_to_space_matches_tf_channel_order():
    n, h, w, bs, c = 1, 3, 2, 2, 3
    x = np.arange(n * h * w * bs * bs * c, dtype=np.float32).reshape(n, h, w, bs * bs * c)
    # TF: output[b, h*bs+i, w*bs+j, k] = input[b, h, w, (i*bs + j)*C + k]
    expected = np.empty((n, h * bs, w * bs, c), np.float32)
    for i in range(bs):
        for j in range(bs):
            expected[:, i::bs, j::bs, :] = x[..., (i * bs + j) * c : (i * bs + j + 1) * c]
    got = run_op("DEPTH_TO_SPACE", x, [], expected.shape, {"block_size": bs})
    np.testing.assert_array_equal(got, expected)


# -- shape ops and elementwise ---------------------------------------------------------
def test_reshape_uses_nhwc_order_after_nchw_producer():
    """A 4-D tensor produced in NCHW (here by a 1×1 conv) must be flattened in NHWC order."""
    x, w = randn(1, 3, 4, 2), np.eye(2, dtype=np.float32).reshape(2, 1, 1, 2)
    tensors = [
        act("x", x.shape), const("w", w), const("b", np.zeros(2, np.float32)), act("c", x.shape),
        const("shape", np.array([1, 24, 1], np.int32)), act("y", (1, 24, 1)),
    ]  # fmt: skip
    conv = Op(
        "CONV_2D", [0, 1, 2], [3], {"padding": "VALID", "stride": (1, 1), "dilation": (1, 1), "activation": "NONE"}
    )
    got = run(tensors, [conv, Op("RESHAPE", [3, 4], [5])], [0], [5], x)[0]
    np.testing.assert_array_equal(got, x.reshape(1, 24, 1))


def test_concatenation_3d_and_4d():
    a, b = randn(1, 6, 2), randn(1, 3, 2)
    got = run_op("CONCATENATION", a, [b], (1, 9, 2), {"axis": 1, "activation": "NONE"})
    np.testing.assert_array_equal(got, np.concatenate([a, b], axis=1))
    a4, b4 = randn(1, 2, 3, 4), randn(1, 2, 3, 5)
    got4 = run_op("CONCATENATION", a4, [b4], (1, 2, 3, 9), {"axis": -1, "activation": "RELU"})
    np.testing.assert_array_equal(got4, np.maximum(np.concatenate([a4, b4], axis=3), 0))


def test_add_with_relu6_and_logistic_chain():
    x, y = randn(1, 4, 4, 3) * 5, randn(1, 4, 4, 3) * 5
    tensors = [act("x", x.shape), act("y", y.shape), act("s", x.shape), act("z", x.shape)]
    ops = [Op("ADD", [0, 1], [2], {"activation": "RELU6"}), Op("LOGISTIC", [2], [3])]
    got = run(tensors, ops, [0, 1], [3], x, y)[0]
    np.testing.assert_allclose(got, 1 / (1 + np.exp(-np.clip(x + y, 0, 6))), atol=1e-6)


def test_add_broadcast_constant_vector_on_4d():
    x, bias = randn(1, 3, 4, 5), randn(5)
    got = run_op("ADD", x, [bias], x.shape, {"activation": "NONE"})
    np.testing.assert_allclose(got, x + bias, atol=1e-6)


# -- DEQUANTIZE / DENSIFY ------------------------------------------------------------------
def test_dequantize_float16_weights_folded_into_conv():
    x, w16, b = randn(1, 5, 5, 2), randn(3, 3, 3, 2).astype(np.float16), randn(3)
    tensors = [act("x", x.shape), const("w16", w16), act("w", w16.shape), const("b", b), act("y", (1, 5, 5, 3))]
    ops = [
        Op("DEQUANTIZE", [1], [2]),
        Op("CONV_2D", [0, 2, 3], [4], {"padding": "SAME", "stride": (1, 1), "dilation": (1, 1), "activation": "NONE"}),
    ]
    got = run(tensors, ops, [0], [4], x)[0]
    np.testing.assert_allclose(got, conv_ref(x, w16.astype(np.float32), b, (1, 1), "SAME"), atol=1e-4)


def test_dequantize_computed_float16_input_becomes_cast():
    x = randn(2, 3).astype(np.float16)
    got = run_op("DEQUANTIZE", x, [], x.shape, {})
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, x.astype(np.float32))


def test_dequantize_int8_per_channel():
    q = np.array([[-128, 0, 127], [5, -5, 10]], np.int8)
    quant = Quantization(scale=np.array([0.5, 0.25], np.float32), zero_point=np.array([1, -2]), axis=0)
    expected = np.array([[-64.5, -0.5, 63.0], [1.75, -0.75, 3.0]], np.float32)
    np.testing.assert_allclose(dequantize(q, quant), expected)


def csr_encode(dense: np.ndarray, formats: list[str]) -> tuple[np.ndarray, Sparsity]:
    """Test-side encoder (identity traversal order, no blocks): the inverse of densify."""
    dims: list[DimMetadata] = []
    parents = [()]  # index prefixes present at the current level
    for level, fmt in enumerate(formats):
        size = dense.shape[level]
        if fmt == "DENSE":
            dims.append(DimMetadata("DENSE", dense_size=size))
            parents = [p + (i,) for p in parents for i in range(size)]
        else:
            segments, indices, children = [0], [], []
            for p in parents:
                sub = dense[p]
                for i in range(size):
                    if np.any(sub[i] != 0):
                        indices.append(i)
                        children.append(p + (i,))
                segments.append(len(indices))
            dims.append(
                DimMetadata("SPARSE_CSR", segments=np.array(segments), indices=np.array(indices, dtype=np.int64))
            )
            parents = children
    values = np.array([dense[p] for p in parents], dense.dtype)
    return values, Sparsity(tuple(range(dense.ndim)), (), dims)


@settings(max_examples=60, deadline=None)
@given(
    shape=st.lists(st.integers(1, 4), min_size=1, max_size=4),
    seed=st.integers(0, 2**31 - 1),
    density=st.floats(0.0, 1.0),
    data=st.data(),
)
def test_densify_roundtrip(shape, seed, density, data):
    rng = np.random.default_rng(seed)
    dense = (rng.standard_normal(shape) * (rng.random(shape) < density)).astype(np.float16)
    formats = data.draw(st.lists(st.sampled_from(["DENSE", "SPARSE_CSR"]), min_size=len(shape), max_size=len(shape)))
    values, sparsity = csr_encode(dense, formats)
    np.testing.assert_array_equal(densify(values, dense.shape, sparsity), dense)


def test_densify_block_sparse_example():
    """TFLite's documented 4×4 example with 2×2 blocks (traversal 0,1,2,3; block map 0,1)."""
    dense = np.array([[1, 0, 2, 3], [0, 4, 0, 0], [0, 0, 0, 0], [0, 0, 5, 6]], np.float32)
    # Block rows: dense 2; block cols: CSR over blocks; inside blocks dense 2×2.
    sparsity = Sparsity(
        traversal_order=(0, 1, 2, 3),
        block_map=(0, 1),
        dim_metadata=[
            DimMetadata("DENSE", dense_size=2),
            DimMetadata("SPARSE_CSR", segments=np.array([0, 2, 3]), indices=np.array([0, 1, 1])),
            DimMetadata("DENSE", dense_size=2),
            DimMetadata("DENSE", dense_size=2),
        ],
    )
    values = np.array([1, 0, 0, 4, 2, 3, 0, 0, 0, 0, 5, 6], np.float32)
    np.testing.assert_array_equal(densify(values, (4, 4), sparsity), dense)


def test_densify_then_dequantize_then_conv_graph():
    """The detector's weight chain: sparse fp16 constant → DENSIFY → DEQUANTIZE → CONV_2D."""
    w = (randn(4, 1, 1, 6) * (RNG.random((4, 1, 1, 6)) < 0.4)).astype(np.float16)
    values, sparsity = csr_encode(w, ["DENSE", "DENSE", "DENSE", "SPARSE_CSR"])
    x, b = randn(1, 3, 3, 6), randn(4)
    tensors = [
        act("x", x.shape), Tensor("ws", w.shape, np.float16, data=values, sparsity=sparsity),
        act("wd16", w.shape, np.float16), act("w", w.shape), const("b", b), act("y", (1, 3, 3, 4)),
    ]  # fmt: skip
    ops = [
        Op("DENSIFY", [1], [2]),
        Op("DEQUANTIZE", [2], [3]),
        Op("CONV_2D", [0, 3, 4], [5], {"padding": "VALID", "stride": (1, 1), "dilation": (1, 1), "activation": "NONE"}),
    ]
    got = run(tensors, ops, [0], [5], x)[0]
    np.testing.assert_allclose(got, conv_ref(x, w.astype(np.float32), b, (1, 1), "VALID"), atol=1e-4)


def test_unsupported_op_is_reported():
    tensors = [act("x", (1, 4)), act("y", (1, 4))]
    with pytest.raises(ValueError, match="got SOFTMAX"):
        graph_to_onnx(Graph(tensors, [Op("SOFTMAX", [0], [1])], [0], [1]))


# -- whole models ------------------------------------------------------------------------------
def _session(path):
    from lifting.blazepose.runtime import make_session

    return make_session(path)


def test_whole_models_match_recorded_tflite_outputs(blazepose_models):
    """ONNX outputs vs. outputs of the original .tflite models (ai-edge-litert 2.3.0),
    recorded by tests/lifting/record_reference.py on a synthetic humanoid."""
    ref = np.load(DATA / "blazepose_reference.npz")
    det = _session(blazepose_models["pose_detection"])
    x = ref["det_input"].astype(np.float32)[None] * (2.0 / 255.0) - 1.0
    boxes, scores = det.run(["Identity", "Identity_1"], {"input_1": x})
    top = ref["det_top_index"]
    np.testing.assert_array_equal(np.argsort(-scores[0, :, 0], kind="stable")[: len(top)], top)
    np.testing.assert_allclose(scores[0, top, 0], ref["det_top_logit"], atol=1e-3)
    np.testing.assert_allclose(boxes[0, top], ref["det_top_boxes"], atol=1e-3)  # 224-pixel offsets

    lm = _session(blazepose_models["pose_landmark_full"])
    x = ref["lm_input"].astype(np.float32)[None] / 255.0
    landmarks, flag, heatmap, world = lm.run(None, {"input_1": x})  # the segmentation mask is cut
    assert flag[0, 0] > 0.9
    np.testing.assert_allclose(flag[0], ref["lm_flag"], atol=1e-4)
    np.testing.assert_allclose(landmarks[0], ref["lm_landmarks"], atol=5e-3)  # crop pixels (x,y,z) and logits
    np.testing.assert_allclose(world[0], ref["lm_world"], atol=1e-4)  # metres
    np.testing.assert_allclose(heatmap[0].max(axis=(0, 1)), ref["lm_heatmap_max"], atol=2e-4)


@pytest.fixture(scope="module")
def tflite_models(tmp_path_factory, blazepose_models):
    pytest.importorskip("ai_edge_litert.interpreter", reason="ai-edge-litert (optional test extra) not installed")
    from lifting.blazepose.assets import (
        MODELS,
        ModelUnavailableError,
        download_wheel,
        read_wheel_member,
    )

    folder = tmp_path_factory.mktemp("tflite")
    try:
        wheel = download_wheel(folder)
    except ModelUnavailableError as exc:
        pytest.skip(f"mediapipe wheel unavailable: {str(exc).splitlines()[0]}")
    return {name: read_wheel_member(wheel, member, sha) for name, (member, sha) in MODELS.items()}


@pytest.mark.parametrize("name,low", [("pose_detection", -1.0), ("pose_landmark_full", 0.0)])
def test_whole_models_match_litert_on_random_input(tflite_models, blazepose_models, name, low):
    from ai_edge_litert.interpreter import Interpreter

    interpreter = Interpreter(model_content=tflite_models[name])
    interpreter.allocate_tensors()
    inp = interpreter.get_input_details()[0]
    x = np.random.default_rng(7).uniform(low, 1.0, inp["shape"]).astype(np.float32)
    interpreter.set_tensor(inp["index"], x)
    interpreter.invoke()
    expected = {d["name"]: interpreter.get_tensor(d["index"]) for d in interpreter.get_output_details()}
    session = _session(blazepose_models[name])
    for out, got in zip(session.get_outputs(), session.run(None, {"input_1": x})):
        ref = expected[out.name]
        assert got.shape == ref.shape
        np.testing.assert_allclose(got, ref, atol=1e-3 * max(1.0, float(np.abs(ref).max())), err_msg=out.name)
