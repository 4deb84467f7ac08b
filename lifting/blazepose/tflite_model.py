"""A small in-memory description of a TFLite model, read from its flatbuffer.

The converter works on this description rather than on the flatbuffer
objects, so tests can build one-op graphs directly in Python.

Only what the BlazePose models need is read: the first subgraph, tensor
shapes/types/constant data, sparsity and quantization parameters, and the
builtin options of the supported operators (as plain dicts).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import tflite

_TENSOR_DTYPES = {
    tflite.TensorType.FLOAT32: np.float32,
    tflite.TensorType.FLOAT16: np.float16,
    tflite.TensorType.INT32: np.int32,
    tflite.TensorType.UINT8: np.uint8,
    tflite.TensorType.INT64: np.int64,
    tflite.TensorType.INT8: np.int8,
    tflite.TensorType.INT16: np.int16,
}

_ACTIVATIONS = {
    tflite.ActivationFunctionType.NONE: "NONE",
    tflite.ActivationFunctionType.RELU: "RELU",
    tflite.ActivationFunctionType.RELU_N1_TO_1: "RELU_N1_TO_1",
    tflite.ActivationFunctionType.RELU6: "RELU6",
    tflite.ActivationFunctionType.TANH: "TANH",
}

_PADDINGS = {tflite.Padding.SAME: "SAME", tflite.Padding.VALID: "VALID"}

_OPCODE_NAMES = {value: name for name, value in vars(tflite.BuiltinOperator).items() if not name.startswith("_")}

_INDEX_VECTORS = {
    tflite.SparseIndexVector.Int32Vector: tflite.Int32Vector,
    tflite.SparseIndexVector.Uint16Vector: tflite.Uint16Vector,
    tflite.SparseIndexVector.Uint8Vector: tflite.Uint8Vector,
}


@dataclass
class DimMetadata:
    """Metadata of one traversal dimension of a sparse tensor.

    ``format`` is "DENSE" (only ``dense_size`` is used) or "SPARSE_CSR"
    (``segments`` has one entry per parent position plus one, ``indices``
    one entry per stored child).
    """

    format: str
    dense_size: int = 0
    segments: np.ndarray | None = None
    indices: np.ndarray | None = None


@dataclass
class Sparsity:
    """TFLite sparsity parameters (see tensorflow/lite/schema/schema.fbs).

    ``traversal_order`` lists the original dimensions first, then the block
    dimensions (numbered from the tensor's rank on); ``block_map[k]`` names the
    original dimension that block dimension ``rank + k`` subdivides.
    """

    traversal_order: tuple[int, ...]
    block_map: tuple[int, ...]
    dim_metadata: list[DimMetadata]


@dataclass
class Quantization:
    """Affine quantization: real = scale * (q - zero_point) along ``axis``."""

    scale: np.ndarray
    zero_point: np.ndarray
    axis: int = 0


@dataclass
class Tensor:
    """One tensor; ``data`` is set for constants (the packed values if sparse)."""

    name: str
    shape: tuple[int, ...]
    dtype: type
    data: np.ndarray | None = None
    sparsity: Sparsity | None = None
    quantization: Quantization | None = None


@dataclass
class Op:
    """One operator: builtin name (e.g. "CONV_2D"), tensor ids (-1 = absent), options."""

    kind: str
    inputs: list[int]
    outputs: list[int]
    options: dict = field(default_factory=dict)


@dataclass
class Graph:
    """A single subgraph: tensors, operators in execution order, graph inputs/outputs."""

    tensors: list[Tensor]
    ops: list[Op]
    inputs: list[int]
    outputs: list[int]


def read_tflite(data: bytes) -> Graph:
    """Parse a ``.tflite`` flatbuffer into a :class:`Graph` (first subgraph only)."""
    if len(data) < 8 or data[4:8] != b"TFL3":
        raise ValueError(f"expected a TFLite flatbuffer (identifier 'TFL3'), got {data[4:8]!r}")
    model = tflite.Model.GetRootAsModel(data, 0)
    if model.SubgraphsLength() < 1:
        raise ValueError("expected at least one subgraph in the TFLite model, got 0")
    sub = model.Subgraphs(0)
    tensors = [_read_tensor(model, data, sub.Tensors(i)) for i in range(sub.TensorsLength())]
    ops = [_read_op(model, sub.Operators(i)) for i in range(sub.OperatorsLength())]
    inputs = [int(sub.Inputs(i)) for i in range(sub.InputsLength())]
    outputs = [int(sub.Outputs(i)) for i in range(sub.OutputsLength())]
    return Graph(tensors=tensors, ops=ops, inputs=inputs, outputs=outputs)


def _read_tensor(model, data: bytes, t) -> Tensor:
    type_code = t.Type()
    if type_code not in _TENSOR_DTYPES:
        raise ValueError(f"tensor {t.Name()!r}: expected a numeric tensor type, got type code {type_code}")
    dtype = _TENSOR_DTYPES[type_code]
    shape = tuple(int(s) for s in t.ShapeAsNumpy()) if t.ShapeLength() else ()
    raw = _buffer_bytes(model, data, t.Buffer())
    values = np.frombuffer(raw, dtype=dtype).copy() if raw else None
    sparsity = _read_sparsity(t.Sparsity()) if t.Sparsity() is not None else None
    if values is not None and sparsity is None:
        values = values.reshape(shape)
    return Tensor(
        name=t.Name().decode("utf-8"),
        shape=shape,
        dtype=dtype,
        data=values,
        sparsity=sparsity,
        quantization=_read_quantization(t.Quantization()),
    )


def _buffer_bytes(model, data: bytes, index: int) -> bytes:
    buf = model.Buffers(index)
    if buf is None:
        return b""
    if buf.DataLength():
        return buf.DataAsNumpy().tobytes()
    # Buffers may live outside the flatbuffer (offset/size), as in models > 2 GB.
    offset, size = buf.Offset(), buf.Size()
    if offset > 1 and size:
        return bytes(data[offset : offset + size])
    return b""


def _read_quantization(q) -> Quantization | None:
    if q is None or q.ScaleLength() == 0:
        return None
    zero_point = q.ZeroPointAsNumpy() if q.ZeroPointLength() else np.zeros(q.ScaleLength(), np.int64)
    return Quantization(
        scale=np.asarray(q.ScaleAsNumpy(), np.float32),
        zero_point=np.asarray(zero_point, np.int64),
        axis=int(q.QuantizedDimension()),
    )


def _index_vector(kind: int, table) -> np.ndarray | None:
    if kind == tflite.SparseIndexVector.NONE or table is None:
        return None
    vec = _INDEX_VECTORS[kind]()
    vec.Init(table.Bytes, table.Pos)
    return np.asarray(vec.ValuesAsNumpy(), np.int64) if vec.ValuesLength() else np.zeros(0, np.int64)


def _read_sparsity(s) -> Sparsity:
    dims = []
    for i in range(s.DimMetadataLength()):
        d = s.DimMetadata(i)
        if d.Format() == tflite.DimensionType.DENSE:
            dims.append(DimMetadata("DENSE", dense_size=int(d.DenseSize())))
        else:
            dims.append(
                DimMetadata(
                    "SPARSE_CSR",
                    segments=_index_vector(d.ArraySegmentsType(), d.ArraySegments()),
                    indices=_index_vector(d.ArrayIndicesType(), d.ArrayIndices()),
                )
            )
    traversal = tuple(int(v) for v in s.TraversalOrderAsNumpy()) if s.TraversalOrderLength() else ()
    block_map = tuple(int(v) for v in s.BlockMapAsNumpy()) if s.BlockMapLength() else ()
    return Sparsity(traversal_order=traversal, block_map=block_map, dim_metadata=dims)


def _options(op, cls):
    table = op.BuiltinOptions()
    if table is None:
        return None
    opts = cls()
    opts.Init(table.Bytes, table.Pos)
    return opts


def _conv_options(o) -> dict:
    return {
        "padding": _PADDINGS[o.Padding()],
        "stride": (int(o.StrideH()), int(o.StrideW())),
        "dilation": (int(o.DilationHFactor()), int(o.DilationWFactor())),
        "activation": _ACTIVATIONS[o.FusedActivationFunction()],
    }


def _read_op(model, op) -> Op:
    code = model.OperatorCodes(op.OpcodeIndex())
    kind = _OPCODE_NAMES.get(max(code.BuiltinCode(), code.DeprecatedBuiltinCode()), "CUSTOM")
    options: dict = {}
    if kind == "CONV_2D":
        options = _conv_options(_options(op, tflite.Conv2DOptions))
    elif kind == "DEPTHWISE_CONV_2D":
        o = _options(op, tflite.DepthwiseConv2DOptions)
        options = _conv_options(o)
        options["depth_multiplier"] = int(o.DepthMultiplier())
    elif kind == "MAX_POOL_2D":
        o = _options(op, tflite.Pool2DOptions)
        options = {
            "padding": _PADDINGS[o.Padding()],
            "stride": (int(o.StrideH()), int(o.StrideW())),
            "filter": (int(o.FilterHeight()), int(o.FilterWidth())),
            "activation": _ACTIVATIONS[o.FusedActivationFunction()],
        }
    elif kind == "ADD":
        o = _options(op, tflite.AddOptions)
        options = {"activation": _ACTIVATIONS[o.FusedActivationFunction()] if o else "NONE"}
    elif kind == "CONCATENATION":
        o = _options(op, tflite.ConcatenationOptions)
        options = {"axis": int(o.Axis()), "activation": _ACTIVATIONS[o.FusedActivationFunction()]}
    elif kind == "RESIZE_BILINEAR":
        o = _options(op, tflite.ResizeBilinearOptions)
        options = {"align_corners": bool(o.AlignCorners()), "half_pixel_centers": bool(o.HalfPixelCenters())}
    elif kind == "DEPTH_TO_SPACE":
        options = {"block_size": int(_options(op, tflite.DepthToSpaceOptions).BlockSize())}
    elif kind == "RESHAPE":
        o = _options(op, tflite.ReshapeOptions)
        if o is not None and o.NewShapeLength():
            options = {"new_shape": tuple(int(v) for v in o.NewShapeAsNumpy())}
    return Op(
        kind=kind,
        inputs=[int(op.Inputs(i)) for i in range(op.InputsLength())],
        outputs=[int(op.Outputs(i)) for i in range(op.OutputsLength())],
        options=options,
    )
