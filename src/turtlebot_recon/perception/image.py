"""Camera frames to greyscale arrays, with the checks a detector node needs (ROS-free: the node
passes the message's fields). Raises ``ImageError`` with one line naming what is wrong."""
from __future__ import annotations

import cv2
import numpy as np

ENCODINGS = ("mono8", "rgb8", "bgr8")      # sensor_msgs/Image encodings read; others refused


class ImageError(ValueError):
    """A frame that cannot be read; the message says why."""


def raw_to_gray(encoding: str, height: int, width: int, step: int, data: bytes) -> np.ndarray:
    """A sensor_msgs/Image's fields → greyscale uint8 (height, width)."""
    if encoding not in ENCODINGS:
        raise ImageError(f"image encoding '{encoding}' is not supported (supported: {', '.join(ENCODINGS)})")
    if height <= 0 or width <= 0:
        raise ImageError(f"image is empty ({width} x {height})")
    channels = 1 if encoding == "mono8" else 3
    if step < width * channels or len(data) < step * height:
        raise ImageError(f"image data too short: {len(data)} bytes for {width} x {height} {encoding} "
                         f"with step {step}")
    rows = np.frombuffer(data, np.uint8, count=step * height).reshape(height, step)
    img = rows[:, :width * channels].reshape(height, width, channels)
    if channels == 1:
        return np.ascontiguousarray(img[..., 0])
    return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY if encoding == "rgb8" else cv2.COLOR_BGR2GRAY)


def compressed_to_gray(fmt: str, data: bytes) -> np.ndarray:
    """A sensor_msgs/CompressedImage's fields (JPEG or PNG) → greyscale uint8."""
    if len(data) == 0:
        raise ImageError(f"compressed image ({fmt or 'no format'}) has no data")
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
    if img is None or img.size == 0:
        raise ImageError(f"compressed image ({fmt or 'no format'}, {len(data)} bytes) cannot be decoded")
    return img


def camera_model(K, D, width: int, height: int, image_shape: tuple) -> tuple:
    """camera_info's K (9) and D → (3x3, D array), checked against the image."""
    K = np.asarray(K, np.float64).reshape(-1)
    if K.size != 9 or not np.isfinite(K).all() or K[0] <= 0 or K[4] <= 0:
        raise ImageError(f"camera_info K has no positive focal lengths (K = {K.tolist()}): "
                         "the camera is not calibrated")
    if (width, height) != (0, 0) and (height, width) != tuple(image_shape[:2]):
        raise ImageError(f"camera_info is for {width} x {height} but the image is "
                         f"{image_shape[1]} x {image_shape[0]}")
    D = np.asarray(D, np.float64).reshape(-1)
    if not np.isfinite(D).all():
        raise ImageError(f"camera_info D is not finite: {D.tolist()}")
    return K.reshape(3, 3), D
