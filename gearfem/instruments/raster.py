"""Visibility by z-buffer: which triangle a camera's sample ray meets first, and where (numpy).

Triangles are given in screen coordinates: ``(sx, sy)`` in units of the sample spacing, sample
``(i, j)`` (column i, row j) at the integer point ``(i, j)``, and the depth ``z`` > 0 along the
viewing direction. A sample lies in a triangle when its three edge functions (screen-space
barycentric coordinates) are >= 0; of the triangles containing a sample the one with the smallest
depth is seen. Depth and the barycentric weights of the hit point are perspective-correct (1/z is
linear in screen space for a planar triangle under a pinhole projection), so the weights
interpolate the vertex values at the true 3D point the ray meets.

The work is vectorised over the (triangle, candidate sample) pairs of each triangle's bounding
box, in chunks that bound the memory.
"""

from __future__ import annotations

import dataclasses

import numpy as np

CHUNK_CANDIDATES = 4_000_000


@dataclasses.dataclass
class Hits:
    """First hits on a ``height`` x ``width`` sample grid (row-major, flat).

    ``triangle``: index of the triangle seen (-1: none); ``weights``: (n, 3) perspective-correct
    barycentric weights of the hit point; ``depth``: its depth (inf: none).
    """

    triangle: np.ndarray
    weights: np.ndarray
    depth: np.ndarray
    width: int
    height: int

    @classmethod
    def empty(cls, width: int, height: int) -> Hits:
        n = width * height
        return cls(
            np.full(n, -1, dtype=np.int64),
            np.zeros((n, 3)),
            np.full(n, np.inf),
            width,
            height,
        )


def rasterize(screen: np.ndarray, width: int, height: int, hits: Hits | None = None) -> Hits:
    """First hits of the triangles ``screen`` (t, 3, 3: sx, sy, z per vertex) on the sample grid.

    ``hits``: an existing buffer to merge into (triangle indices then refer to this call's
    triangles offset by nothing: callers concatenate their triangle lists first).
    """
    out = hits if hits is not None else Hits.empty(width, height)
    if len(screen) == 0:
        return out
    x, y, z = screen[..., 0], screen[..., 1], screen[..., 2]
    x0 = np.ceil(x.min(axis=1)).astype(np.int64)
    x1 = np.floor(x.max(axis=1)).astype(np.int64)
    y0 = np.ceil(y.min(axis=1)).astype(np.int64)
    y1 = np.floor(y.max(axis=1)).astype(np.int64)
    np.maximum(x0, 0, out=x0)
    np.minimum(x1, width - 1, out=x1)
    np.maximum(y0, 0, out=y0)
    np.minimum(y1, height - 1, out=y1)
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    ok = (x1 >= x0) & (y1 >= y0) & (np.abs(area2) > 1e-14) & np.all(z > 0.0, axis=1)
    idx = np.flatnonzero(ok)
    if len(idx) == 0:
        return out
    nx = x1[idx] - x0[idx] + 1
    counts = nx * (y1[idx] - y0[idx] + 1)
    ends = np.cumsum(counts)
    start = 0
    while start < len(idx):
        base = ends[start - 1] if start else 0
        stop = int(np.searchsorted(ends, base + CHUNK_CANDIDATES, side="right"))
        stop = max(stop, start + 1)
        _chunk(idx[start:stop], counts[start:stop], nx[start:stop], x0, y0, x, y, z, area2, out)
        start = stop
    return out


def _chunk(tri, counts, nx, x0, y0, x, y, z, area2, out: Hits) -> None:
    total = int(counts.sum())
    owner = np.repeat(np.arange(len(tri)), counts)
    offset = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    t = tri[owner]
    sx = x0[t] + offset % nx[owner]
    sy = y0[t] + offset // nx[owner]
    X, Y = x[t], y[t]
    # screen-space barycentrics from the edge functions
    b0 = (X[:, 1] - sx) * (Y[:, 2] - sy) - (X[:, 2] - sx) * (Y[:, 1] - sy)
    b1 = (X[:, 2] - sx) * (Y[:, 0] - sy) - (X[:, 0] - sx) * (Y[:, 2] - sy)
    b2 = (X[:, 0] - sx) * (Y[:, 1] - sy) - (X[:, 1] - sx) * (Y[:, 0] - sy)
    a = area2[t]
    b0, b1, b2 = b0 / a, b1 / a, b2 / a
    inside = (b0 >= 0.0) & (b1 >= 0.0) & (b2 >= 0.0)
    if not np.any(inside):
        return
    t, sx, sy = t[inside], sx[inside], sy[inside]
    b = np.stack([b0[inside], b1[inside], b2[inside]], axis=1)
    Z = z[t]
    w = b / Z  # perspective-correct: interpolate 1/z linearly
    inv = w.sum(axis=1)
    depth = 1.0 / inv
    w = w / inv[:, None]
    s = sy * out.width + sx
    order = np.lexsort((depth, s))
    s_sorted = s[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = s_sorted[1:] != s_sorted[:-1]
    win = order[first]
    s_win = s[win]
    better = depth[win] < out.depth[s_win]
    s_win, win = s_win[better], win[better]
    out.depth[s_win] = depth[win]
    out.triangle[s_win] = t[win]
    out.weights[s_win] = w[win]
