"""3D labels that never overlap in the default camera view.

The default camera (``camera``) looks at the fixed point from ``EYE_DISTANCE`` times the scene's
reach (the farthest thing drawn, ``visuals.reach``) along ``EYE_DIRECTION``, space z up.  At each sample every label's anchor is projected with a pinhole
camera; a label whose box overlaps the box of a label earlier in the priority order is hidden at
that sample (its position becomes NaN, which the viewer does not draw).  The projection is
conservative: it assumes a wider field of view (``FOV_DEG``) and a smaller view (``VIEW_PIXELS``
high) than the default layout at 1280×720, so labels look closer together here than on screen.
A label box is ``CHAR_PIXELS`` per character plus ``PAD_PIXELS`` wide and ``LINE_PIXELS`` high.
"""

from __future__ import annotations

import numpy as np

EYE_DIRECTION = np.array([1.0, -1.6, 0.9]) / np.linalg.norm([1.0, -1.6, 0.9])
EYE_DISTANCE = 2.6  # scene reaches
UP = np.array([0.0, 0.0, 1.0])
FOV_DEG = 70.0
VIEW_PIXELS = 480.0
CHAR_PIXELS, PAD_PIXELS, LINE_PIXELS = 8.0, 14.0, 20.0


def camera(reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(eye position, look target) of the default 3D view, space frame, for a scene whose drawn
    things all lie within ``reach`` of the fixed point."""
    return EYE_DISTANCE * reach * EYE_DIRECTION, np.zeros(3)


def project(points: np.ndarray, eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Pixel offsets (..., 2) from the view's centre of space points (..., 3)."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, UP)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = points - eye
    depth = d @ forward
    focal = 0.5 * VIEW_PIXELS / np.tan(np.radians(FOV_DEG) / 2)
    return np.stack([d @ right, d @ up], axis=-1) / depth[..., None] * focal


def overlaps(a: np.ndarray, b: np.ndarray, text_a: str, text_b: str) -> np.ndarray:
    """(N,) True where the label boxes centred at pixel positions a, b (N, 2) overlap."""
    half_width = 0.5 * (CHAR_PIXELS * (len(text_a) + len(text_b)) + 2 * PAD_PIXELS)
    d = np.abs(a - b)
    return (d[:, 0] < half_width) & (d[:, 1] < LINE_PIXELS)


def declutter(anchors: list[tuple[str, np.ndarray]], eye: np.ndarray, target: np.ndarray) -> list[np.ndarray]:
    """For labels in priority order, each (text, (N, 3) anchors; NaN = not shown): the (N, 3)
    positions to draw, NaN where the label would overlap an earlier one that is shown."""
    drawn: list[tuple[str, np.ndarray]] = []
    out = []
    for text, points in anchors:
        pixels = project(points, eye, target)
        hidden = ~np.all(np.isfinite(pixels), axis=1)
        for other_text, other in drawn:
            hidden |= overlaps(pixels, other, text, other_text) & np.all(np.isfinite(other), axis=1)
        pixels = np.where(hidden[:, None], np.nan, pixels)
        drawn.append((text, pixels))
        out.append(np.where(hidden[:, None], np.nan, points))
    return out
