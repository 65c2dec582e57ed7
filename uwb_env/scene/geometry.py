"""Planar geometry kernels: segment crossings, point-segment distances.

All kernels broadcast over leading axes; points are row vectors ``(..., 2)`` in metres.
"""

from __future__ import annotations

import numpy as np

from uwb_env.typing import BoolArray, FloatArray


def _cross2(a: FloatArray, b: FloatArray) -> FloatArray:
    """z-component of the 2-D cross product, ``(..., 2), (..., 2) -> (...)``."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def segments_cross(p0: FloatArray, p1: FloatArray, a: FloatArray, b: FloatArray) -> BoolArray:
    """Whether segments ``p0->p1`` properly cross segments ``a->b``.

    Args:
        p0, p1: ``(N, 2)`` path segment end points [m].
        a, b: ``(W, 2)`` wall segment end points [m].

    Returns:
        ``(N, W)`` True where the open segments intersect (touching an end point counts as crossing; collinear
        overlaps do not).

    Notes:
        Parametric test: p0 + t (p1 - p0) = a + u (b - a) with t, u in [0, 1], solved with 2-D cross products.
    """
    d = (p1 - p0)[:, None, :]  # (N, 1, 2)
    e = (b - a)[None, :, :]  # (1, W, 2)
    w = a[None, :, :] - p0[:, None, :]  # (N, W, 2)
    denom = _cross2(d, e)  # (N, W)
    parallel = np.abs(denom) < 1e-12
    safe = np.where(parallel, 1.0, denom)
    t = _cross2(w, e) / safe
    u = _cross2(w, d) / safe
    return ~parallel & (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)


def point_segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distance from points to segments.

    Args:
        p: ``(N, 2)`` points [m]; a, b: ``(W, 2)`` segment end points [m].

    Returns:
        ``(N, W)`` Euclidean distance [m].
    """
    ab = b - a  # (W, 2)
    ap = p[:, None, :] - a[None, :, :]  # (N, W, 2)
    t = np.clip(np.einsum("nwk,wk->nw", ap, ab) / np.einsum("wk,wk->w", ab, ab), 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - closest, axis=-1)
