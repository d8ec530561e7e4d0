"""Hand-made ROS map_server maps for the tests: a YAML beside a PGM (P5 or P2, 8 or 16 bits) or a
PNG (any Pillow mode), and the way back from a world's walls to the map's cells."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from navstress.world.world import World


def write_pgm(path: Path, img: np.ndarray, maxval: int = 255, plain: bool = False, comment: bool = True) -> Path:
    """``img`` (rows top first) as a PGM: P5 (binary; 16-bit big-endian above 255) or P2 (text)."""
    h, w = img.shape
    head = b"P2\n" if plain else b"P5\n"
    if comment:
        head += b"# CREATOR: navstress tests\n"
    head += b"%d %d\n%d\n" % (w, h, maxval)
    if plain:
        body = "\n".join(" ".join(str(int(v)) for v in row) for row in img).encode() + b"\n"
    else:
        body = img.astype(">u2" if maxval > 255 else "u1").tobytes()
    path.write_bytes(head + body)
    return path


def write_png(path: Path, img: np.ndarray, mode: str | None = None) -> Path:
    from PIL import Image

    Image.fromarray(img, mode=mode).save(path) if mode else Image.fromarray(img).save(path)
    return path


def write_yaml(path: Path, image: str, **fields: Any) -> Path:
    data = {"image": image, "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196, **fields}
    lines = []
    for k, v in data.items():
        if v is None:
            continue
        lines.append(f"{k}: {v}" if not isinstance(v, list) else f"{k}: [{', '.join(str(x) for x in v)}]")
    path.write_text("\n".join(lines) + "\n")
    return path


def walls_to_cells(world: World, shape: tuple[int, int], resolution: float, origin_xy: tuple[float, float],
                   yaw: float = 0.0) -> np.ndarray:
    """The map cells (rows top first, as the image) that the world's walls cover: each wall's
    centre and size taken back to the map's own frame (through ``World.source.origin``) and then
    to the image's cells. Counts per cell (1 = covered once)."""
    assert world.source is not None
    h, w = shape
    out = np.zeros(shape, np.int64)
    c, s = math.cos(yaw), math.sin(yaw)
    for o in world.obstacles:
        assert o.kind == "wall" and o.shape == "box"
        assert abs(o.yaw - yaw) < 1e-12
        mx, my = world.source.to_source(o.x, o.y)  # the map frame
        dx, dy = mx - origin_xy[0], my - origin_xy[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy  # the image's unturned frame (lower-left corner at 0)
        j0 = (lx - o.size[0] / 2) / resolution
        j1 = (lx + o.size[0] / 2) / resolution
        i0 = (ly - o.size[1] / 2) / resolution
        i1 = (ly + o.size[1] / 2) / resolution
        for v in (j0, j1, i0, i1):
            assert abs(v - round(v)) < 1e-6, (o, v)
        j0, j1, i0, i1 = (int(round(v)) for v in (j0, j1, i0, i1))
        assert 0 <= j0 < j1 <= w and 0 <= i0 < i1 <= h, (o, j0, j1, i0, i1)
        out[h - i1:h - i0, j0:j1] += 1
    return out
