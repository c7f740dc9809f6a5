"""Geometry of the lunar field for the compiled kernel (spec LUNAR-FORAGING.md sections 2, 5, 7.4, 7.5):
the obstacle rectangle, segments, rays and region discs over the geometry array of
:func:`dronefleet.lunar.layout.kernel_geometry`.

Only + - * / sqrt and comparisons: the results are bit-identical on any CPU.
"""

import numpy as np

from ..jit import njit

# Geometry array (layout.kernel_geometry).
G_W, G_H, G_CX, G_CY, G_RAD, G_KIND, G_CORNERS, G_SPAWN = 0, 1, 2, 5, 8, 11, 12, 20
KIND_NONE, KIND_HARD, KIND_SOFT = 0, 1, 2
#: Region index of a point in no region (regions: T 0, N 1, R 2).
NO_REGION = -1


@njit(cache=True, inline='always')
def _cross(ax, ay, bx, by, cx, cy):
    """z of (b - a) x (c - a): > 0 when c lies left of a -> b."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def inside_quad(px, py, g):
    """The point lies strictly inside the counter-clockwise obstacle rectangle of geometry ``g``."""
    c = G_CORNERS
    for e in range(4):
        f = (e + 1) % 4
        if _cross(g[c + 2 * e], g[c + 2 * e + 1], g[c + 2 * f], g[c + 2 * f + 1], px, py) <= 0.0:
            return False
    return True


@njit(cache=True)
def segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
    """Segments a-b and c-d meet (touching counts)."""
    d1 = _cross(cx, cy, dx, dy, ax, ay)
    d2 = _cross(cx, cy, dx, dy, bx, by)
    d3 = _cross(ax, ay, bx, by, cx, cy)
    d4 = _cross(ax, ay, bx, by, dx, dy)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        return True
    return (d1 == 0.0 or d2 == 0.0 or d3 == 0.0 or d4 == 0.0) and \
        min(ax, bx) <= max(cx, dx) and min(cx, dx) <= max(ax, bx) and \
        min(ay, by) <= max(cy, dy) and min(cy, dy) <= max(ay, by) and \
        ((d1 == 0.0 and _on(cx, cy, dx, dy, ax, ay)) or (d2 == 0.0 and _on(cx, cy, dx, dy, bx, by)) or
         (d3 == 0.0 and _on(ax, ay, bx, by, cx, cy)) or (d4 == 0.0 and _on(ax, ay, bx, by, dx, dy)))


@njit(cache=True, inline='always')
def _on(ax, ay, bx, by, px, py):
    """p (collinear with a-b) lies within the segment's box."""
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit(cache=True)
def segment_blocked(ax, ay, bx, by, g):
    """The segment a-b crosses the hard obstacle of ``g`` (line of sight, section 5)."""
    c = G_CORNERS
    for e in range(4):
        f = (e + 1) % 4
        if segments_cross(ax, ay, bx, by, g[c + 2 * e], g[c + 2 * e + 1], g[c + 2 * f], g[c + 2 * f + 1]):
            return True
    return inside_quad(ax, ay, g)


@njit(cache=True)
def segment_point_dist2(ax, ay, bx, by, px, py):
    """Squared distance from p to the segment a-b."""
    ux = bx - ax
    uy = by - ay
    ll = ux * ux + uy * uy
    t = 0.0
    if ll > 0.0:
        t = ((px - ax) * ux + (py - ay) * uy) / ll
        t = min(1.0, max(0.0, t))
    dx = ax + t * ux - px
    dy = ay + t * uy - py
    return dx * dx + dy * dy


@njit(cache=True)
def disc_hits_quad(px, py, r, g):
    """A disc of radius r at p overlaps the hard obstacle of ``g``."""
    if inside_quad(px, py, g):
        return True
    c = G_CORNERS
    r2 = r * r
    for e in range(4):
        f = (e + 1) % 4
        if segment_point_dist2(g[c + 2 * e], g[c + 2 * e + 1], g[c + 2 * f], g[c + 2 * f + 1], px, py) < r2:
            return True
    return False


@njit(cache=True)
def ray_segment(px, py, dx, dy, ax, ay, bx, by):
    """Distance t >= 0 along the ray p + t d (|d| = 1) to the segment a-b, np.inf if it misses."""
    ex = bx - ax
    ey = by - ay
    den = dx * ey - dy * ex
    if den == 0.0:
        return np.inf
    wx = ax - px
    wy = ay - py
    t = (wx * ey - wy * ex) / den
    s = (wx * dy - wy * dx) / den
    if t >= 0.0 and 0.0 <= s <= 1.0:
        return t
    return np.inf


@njit(cache=True)
def ray_disc(px, py, dx, dy, qx, qy, r):
    """Distance t >= 0 along the ray p + t d (|d| = 1) to the disc of radius r at q, np.inf if it
    misses (0 if p is inside it)."""
    wx = qx - px
    wy = qy - py
    t = wx * dx + wy * dy
    perp2 = wx * wx + wy * wy - t * t
    r2 = r * r
    if wx * wx + wy * wy <= r2:
        return 0.0
    if t < 0.0 or perp2 >= r2:
        return np.inf
    return t - np.sqrt(r2 - perp2)


@njit(cache=True)
def ray_walls(px, py, dx, dy, w, h):
    """Distance along the ray p + t d to the field's walls."""
    t = np.inf
    if dx < 0.0:
        t = min(t, -px / dx)
    elif dx > 0.0:
        t = min(t, (w - px) / dx)
    if dy < 0.0:
        t = min(t, -py / dy)
    elif dy > 0.0:
        t = min(t, (h - py) / dy)
    return t


@njit(cache=True)
def region_of(px, py, g):
    """Index of the region (T 0, N 1, R 2) whose disc holds p (centre distance < radius), or -1."""
    for q in range(3):
        dx = px - g[G_CX + q]
        dy = py - g[G_CY + q]
        if dx * dx + dy * dy < g[G_RAD + q] * g[G_RAD + q]:
            return q
    return NO_REGION


@njit(cache=True)
def near_box(px, py, reach, box):
    """p is within ``reach`` of the box (xmin, ymin, xmax, ymax)."""
    return box[0] - reach <= px <= box[2] + reach and box[1] - reach <= py <= box[3] + reach


@njit(cache=True)
def heading_alignment(px, py, dx, dy, g, key):
    """cos of the angle between (dx, dy) and the direction from p to region ``key``; NaN if
    either has length 0."""
    ex = g[G_CX + key] - px
    ey = g[G_CY + key] - py
    n = np.sqrt((dx * dx + dy * dy) * (ex * ex + ey * ey))
    if n == 0.0:
        return np.nan
    return (dx * ex + dy * ey) / n
