"""BlazePose (MediaPipe) pose tracking through onnxruntime.

Models come from MediaPipe's PyPI wheel and are converted to ONNX by our own converter
(:mod:`lifting.blazepose.tflite2onnx`); see :mod:`lifting.blazepose.assets`. The tracker is
:mod:`lifting.blazepose.tracker`; what it produces (landmark names and edges, :class:`TrackResult`)
is in :mod:`lifting.blazepose.results`, which imports neither onnxruntime nor OpenCV. Nothing is
imported here, so that importing one submodule does not load the others.
"""
