"""A small office as a ROS map_server map (a PGM and its YAML): rooms on both sides of a corridor,
a door from each room into it (what tests and examples/office/ use)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The office's size (m), its map's resolution (m per cell) and the corridor's span in y (m, map frame
#: from the map's lower-left corner).
SIZE_M = (20.0, 12.0)
RESOLUTION = 0.05
CORRIDOR_Y = (4.0, 6.0)
WALL_M = 0.2
DOOR_M = 1.2


def office_cells() -> np.ndarray:
    """The office as occupancy (True: a wall), rows bottom first, columns along x."""
    nx, ny = round(SIZE_M[0] / RESOLUTION), round(SIZE_M[1] / RESOLUTION)
    occ = np.zeros((ny, nx), bool)
    k = round(WALL_M / RESOLUTION)

    def cells(v: float) -> int:
        return round(v / RESOLUTION)

    occ[:k, :] = occ[-k:, :] = True  # outer walls
    occ[:, :k] = occ[:, -k:] = True
    for y in CORRIDOR_Y:  # the corridor's walls, a door per room
        occ[cells(y) - k // 2:cells(y) + k // 2, :] = True
    for x in (7.0, 13.0):  # walls between rooms, below and above the corridor
        occ[:cells(CORRIDOR_Y[0]), cells(x) - k // 2:cells(x) + k // 2] = True
        occ[cells(CORRIDOR_Y[1]):, cells(x) - k // 2:cells(x) + k // 2] = True
    for x0, x1 in ((0.0, 7.0), (7.0, 13.0), (13.0, 20.0)):
        mid = (x0 + x1) / 2
        for y in CORRIDOR_Y:
            occ[cells(y) - k:cells(y) + k, cells(mid - DOOR_M / 2):cells(mid + DOOR_M / 2)] = False
    return occ


def write_office(folder: Path, origin: tuple[float, float] = (-3.0, 2.0), name: str = "office") -> Path:
    """Write ``folder/NAME.pgm`` and ``folder/NAME.yaml`` (the map's lower-left corner at ``origin``
    in its frame); returns the YAML's path."""
    folder.mkdir(parents=True, exist_ok=True)
    img = np.where(office_cells()[::-1], 0, 254).astype(np.uint8)  # image row 0 is the top
    h, w = img.shape
    (folder / f"{name}.pgm").write_bytes(b"P5\n%d %d\n255\n" % (w, h) + img.tobytes())
    yaml = folder / f"{name}.yaml"
    yaml.write_text(f"image: {name}.pgm\nresolution: {RESOLUTION}\norigin: [{origin[0]}, {origin[1]}, 0.0]\n"
                    "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return yaml
