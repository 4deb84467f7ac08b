"""BlazePose (MediaPipe) pose tracking through onnxruntime.

Models come from MediaPipe's PyPI wheel and are converted to ONNX by our own
converter (:mod:`lifting.blazepose.tflite2onnx`); see :mod:`lifting.blazepose.assets`.
"""

from lifting.blazepose.assets import ModelUnavailableError, ensure_models
from lifting.blazepose.landmarks import POSE_LANDMARKS
from lifting.blazepose.tracker import PoseFrame, PoseTracker, TrackResult

__all__ = [
    "POSE_LANDMARKS",
    "ModelUnavailableError",
    "PoseFrame",
    "PoseTracker",
    "TrackResult",
    "ensure_models",
]
