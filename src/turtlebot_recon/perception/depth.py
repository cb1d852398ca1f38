"""Depth images to 3-D points (ROS-free: the node passes the message's fields).

A sensor_msgs/Image of depth (REP 118: ``32FC1`` in metres, NaN where nothing returns, or
``16UC1`` in millimetres, 0 where nothing returns, as real drivers send) becomes a float32
array of metres with NaN for every pixel that returned nothing; ``DepthCamera`` samples it on
a coarse pixel lattice (every ``stride``-th row and column: 640 x 480 at stride 4 is 160 x 120)
and back-projects each sample through the pinhole K into the optical frame (REP 103: z forward,
x right, y down), then moves the points into the map frame by the camera's 4 x 4 pose.

The cloud is organised: one row per sampled pixel, in image order, NaN where the pixel returned
nothing, so that its consumer counts what it skips (``OctomapLayer.insert`` does). Every
refusal is an ``ImageError`` (a ValueError) with one line saying what is wrong.
"""
from __future__ import annotations

import numpy as np

from .image import ImageError, camera_model

DEPTH_ENCODINGS = {"32FC1": np.float32, "16UC1": np.uint16}   # encoding -> pixel type; others refused
MM_PER_M = 1000.0                                              # 16UC1 depth is in millimetres


def depth_metres(encoding: str, height: int, width: int, step: int, data: bytes,
                 is_bigendian: bool = False) -> np.ndarray:
    """A depth sensor_msgs/Image's fields → float32 (height, width) metres, NaN = no return
    (32FC1: NaN, inf or <= 0; 16UC1: 0)."""
    _check_encoding(encoding)
    if height <= 0 or width <= 0:
        raise ImageError(f"depth image is empty ({width} x {height})")
    dtype = np.dtype(DEPTH_ENCODINGS[encoding]).newbyteorder(">" if is_bigendian else "<")
    if step < width * dtype.itemsize or len(data) < step * height:
        raise ImageError(f"depth image data too short: {len(data)} bytes for {width} x {height} "
                         f"{encoding} with step {step}")
    rows = np.frombuffer(data, np.uint8, count=step * height).reshape(height, step)
    pixels = rows[:, :width * dtype.itemsize].copy().view(dtype)
    return to_metres(encoding, pixels)


def to_metres(encoding: str, pixels: np.ndarray) -> np.ndarray:
    """Depth pixels of ``encoding`` (an array of its type) → float32 metres, NaN = no return."""
    _check_encoding(encoding)
    if encoding == "16UC1":
        metres = pixels.astype(np.float32) / np.float32(MM_PER_M)
        metres[pixels == 0] = np.nan
        return metres
    metres = pixels.astype(np.float32)       # a copy: the caller's array is left alone
    metres[~(np.isfinite(metres) & (metres > 0))] = np.nan
    return metres


def _check_encoding(encoding: str) -> None:
    if encoding not in DEPTH_ENCODINGS:
        raise ImageError(f"depth encoding '{encoding}' is not supported "
                         f"(supported: {', '.join(DEPTH_ENCODINGS)})")


def stride_for(width: int, columns: int) -> int:
    """The pixel stride that samples an image ``width`` pixels wide at about ``columns``."""
    return max(1, int(width) // max(1, int(columns)))


class DepthCamera:
    """A pinhole depth camera (camera_info's K and size) sampled every ``stride`` pixels; the
    rays of the sampled pixels are computed once."""

    def __init__(self, K, width: int, height: int, stride: int):
        if width <= 0 or height <= 0:
            raise ImageError(f"camera_info has no image size ({width} x {height})")
        if stride < 1:
            raise ImageError(f"depth stride must be >= 1, got {stride}")
        K, _ = camera_model(K, (), width, height, (height, width))   # refuses an all-zero K
        self.width, self.height, self.stride = int(width), int(height), int(stride)
        v, u = np.mgrid[0:height:stride, 0:width:stride].astype(np.float32)
        # the optical-frame direction of each sampled pixel, scaled to z = 1
        self._x_per_z = ((u - K[0, 2]) / K[0, 0]).ravel()
        self._y_per_z = ((v - K[1, 2]) / K[1, 1]).ravel()
        self.shape = v.shape                   # (rows, cols) of the sampled lattice

    def optical_points(self, depth_m: np.ndarray) -> np.ndarray:
        """float32 (n, 3) points in the optical frame (m), one per sampled pixel in image order,
        NaN where it returned nothing. ``depth_m``: (height, width) metres (``depth_metres``)."""
        depth_m = np.asarray(depth_m)
        if depth_m.shape != (self.height, self.width):
            size = (f"{depth_m.shape[1]} x {depth_m.shape[0]}" if depth_m.ndim == 2
                    else f"of shape {depth_m.shape}")
            raise ImageError(f"camera_info is for {self.width} x {self.height} but the depth image "
                             f"is {size}")
        z = depth_m[::self.stride, ::self.stride].astype(np.float32, copy=False).ravel()
        return np.stack((self._x_per_z * z, self._y_per_z * z, z), axis=1)

    def points(self, depth_m: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """float32 (n, 3) points in the map frame: ``optical_points`` moved by ``pose``, the
        4 x 4 transform map ← optical frame."""
        pose = np.asarray(pose, np.float64)
        if pose.shape != (4, 4) or not np.isfinite(pose).all():
            raise ImageError(f"the camera pose must be a finite 4 x 4 transform, got shape {pose.shape}")
        p = self.optical_points(depth_m)
        rotation = pose[:3, :3].astype(np.float32)
        return p @ rotation.T + pose[:3, 3].astype(np.float32)
