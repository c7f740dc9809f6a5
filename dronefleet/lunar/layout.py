"""Geometry of the lunar model's world (spec section 2): field, regions, obstacle, spawn point.

Everything is defined on the earlier 16.8 x 14.4 m draft layout and scaled by ``layout_scale``
about the origin (0.75 gives the section-2 layout): region centres, the field and the obstacle
corners scale; region radii, robot size and radio range do not. :func:`build` returns a
:class:`Layout` for drawing and :func:`kernel_geometry` the flat array the kernel reads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .params import LunarParams

__all__ = ["Layout", "build", "kernel_geometry", "REGIONS", "FIELD", "CENTRES", "RADIUS",
           "OBSTACLE_LENGTH", "OBSTACLE_WIDTH", "NO_OBSTACLE", "HARD", "SOFT",
           "G_W", "G_H", "G_CX", "G_CY", "G_RAD", "G_KIND", "G_CORNERS", "G_SPAWN", "N_GEOM"]

#: Regions in key order: key F_OUT <-> T (0), F_IN <-> N (1), R <-> R (2).
REGIONS = ("T", "N", "R")
#: Field, centres and obstacle footprint of the draft layout (layout_scale = 1) [m].
FIELD = (16.8, 14.4)
CENTRES = {"N": (3.0, 7.2), "T": (11.4, 11.4), "R": (11.4, 3.0)}
#: Region radius delta_N = delta_T = delta_R [m]; not scaled.
RADIUS = 1.5
#: Obstacle: length across the joining line, width along it (draft layout) [m] (A6).
OBSTACLE_LENGTH, OBSTACLE_WIDTH = 4.8, 1.2
NO_OBSTACLE, HARD, SOFT = 0, 1, 2

# Layout of the kernel's geometry array (float64): field, region centres and radii by key,
# obstacle kind, 4 corners (x0, y0, ..., x3, y3), spawn point.
G_W, G_H = 0, 1
G_CX, G_CY, G_RAD = 2, 5, 8
G_KIND = 11
G_CORNERS = 12
G_SPAWN = 20
N_GEOM = 22


@dataclass(frozen=True, eq=False)
class Layout:
    """One scenario's geometry, scaled (metres).

    Attributes
    ----------
    field : (w, h)
        The walled field [0, w] x [0, h].
    centres : dict
        ``{"N": (x, y), "T": ..., "R": ...}`` region centres.
    radii : dict
        ``{"N": r, "T": r, "R": r}`` region radii (membership: centre distance < r).
    obstacle : ndarray (4, 2) or None
        Corners of the obstacle rectangle, counter-clockwise; None in OPEN.
    kind : "hard", "soft" or None
        Obstacle kind (None in OPEN).
    spawn : (x, y)
        Spawn point (the centre of N).
    """

    field: tuple[float, float]
    centres: dict
    radii: dict
    obstacle: np.ndarray | None
    kind: str | None
    spawn: tuple[float, float]


def _rectangle(a, b):
    """Corners (4, 2), counter-clockwise, of the obstacle centred on the midpoint of region
    centres ``a`` and ``b``: OBSTACLE_WIDTH along a-b, OBSTACLE_LENGTH across it (draft scale)."""
    mx, my = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])
    dx, dy = b[0] - a[0], b[1] - a[1]
    d = math.sqrt(dx * dx + dy * dy)
    ux, uy = dx / d, dy / d                  # along the joining line
    px, py = -uy, ux                         # across it
    hw, hl = 0.5 * OBSTACLE_WIDTH, 0.5 * OBSTACLE_LENGTH
    return np.array([[mx + su * hw * ux + sp * hl * px, my + su * hw * uy + sp * hl * py]
                     for su, sp in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def _draft_obstacle(place: str) -> np.ndarray:
    """Obstacle corners of placement ``place`` ("RT", "NT", "NR") in the draft layout."""
    if place == "RT":
        # Axis-aligned on the vertical R-T line: x in [9, 13.8], y in [6.6, 7.8] (draft).
        return _rectangle(CENTRES["R"], CENTRES["T"])
    corners = _rectangle(CENTRES["N"], CENTRES["T"])
    if place == "NR":
        corners = corners[::-1].copy()       # mirror image in y = 7.2, kept counter-clockwise
        corners[:, 1] = 2.0 * CENTRES["N"][1] - corners[:, 1]
    return corners


def build(params: LunarParams) -> Layout:
    """The geometry of ``params.layout`` at ``params.layout_scale``."""
    s = params.layout_scale
    centres = {name: (c[0] * s, c[1] * s) for name, c in CENTRES.items()}
    if params.layout == "OPEN":
        obstacle, kind = None, None
    else:
        hardness, place = params.layout.split("-")
        obstacle, kind = _draft_obstacle(place) * s, hardness.lower()
    return Layout(field=(FIELD[0] * s, FIELD[1] * s), centres=centres,
                  radii={name: RADIUS for name in CENTRES}, obstacle=obstacle, kind=kind,
                  spawn=centres["N"])


def kernel_geometry(layout: Layout) -> np.ndarray:
    """The kernel's geometry array (N_GEOM,) float64: see the G_* indices (regions in key order)."""
    g = np.zeros(N_GEOM)
    g[G_W], g[G_H] = layout.field
    for key, name in enumerate(REGIONS):
        g[G_CX + key], g[G_CY + key] = layout.centres[name]
        g[G_RAD + key] = layout.radii[name]
    g[G_KIND] = {None: NO_OBSTACLE, "hard": HARD, "soft": SOFT}[layout.kind]
    if layout.obstacle is not None:
        g[G_CORNERS:G_CORNERS + 8] = layout.obstacle.reshape(-1)
    g[G_SPAWN], g[G_SPAWN + 1] = layout.spawn
    return g
