"""The all-in-one lidar scan (terrain and boxes per azimuth column): the reference that the
production box pass (:func:`navstress.sim._raybox.box_pass` after
:func:`navstress.sim._raycast.terrain_kernel`) is compared with, bit for bit. Test code only."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from navstress.sim._raycast import INF, Beams, Box, Ray, TerrainGrid, _ray_box, terrain_kernel

TWO_PI = 2.0 * math.pi


@njit(cache=True, nogil=True, error_model="numpy")
def scan_kernel(grid: TerrainGrid, beams: Beams, params: np.ndarray, boxes: np.ndarray, origin: np.ndarray,
                rot: np.ndarray, out: np.ndarray) -> None:
    """One scan: out[channel, azimuth] = range (inf: no return). Channels ascending in elevation;
    ``params`` a one-record ``SCAN_PARAMS`` array (``max_range``, ``min_range``, ``plane_march``,
    ``walk``), as the production kernels take it.

    The terrain ranges come from :func:`terrain_kernel` (one plane per azimuth column, lowest
    channel first). Boxes come from world-heading sector bins (built per scan), each tested only
    on the contiguous channel range whose world slope can reach it, nearer than the terrain hit.

    :class:`~navstress.sim.lidar.Lidar` runs ``terrain_kernel`` and then the faster box-major
    :func:`navstress.sim._raybox.box_pass`; the per-column box code here is the independent
    all-in-one reference that the tests compare ``box_pass`` against (bit-identical).
    """
    h, cell = grid.heights, grid.cell
    cos_el, sin_el, cos_az, sin_az = beams
    max_range, min_range = params[0].max_range, params[0].min_range
    nch = cos_el.shape[0]
    naz = cos_az.shape[0]
    ox, oy, oz = origin[0], origin[1], origin[2]
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    icell = 1.0 / cell
    tr = np.empty((nch, naz))
    terrain_kernel(grid, beams, params, origin, rot, tr)
    # ---- per-scan box preparation: distances, reachable slopes, heading intervals, bins --
    nb = boxes.shape[0]
    nsec = 360
    sec_w = 2.0 * math.pi / nsec
    dmin = np.empty(nb)
    mlo = np.empty(nb)
    mhi = np.empty(nb)
    alo = np.empty(nb)
    ahi = np.empty(nb)
    for i in range(nb):
        c = boxes[i, 7]
        s = boxes[i, 8]
        px = ox - boxes[i, 0]
        py = oy - boxes[i, 1]
        lx = abs(c * px + s * py)
        ly = abs(-s * px + c * py)
        hx = boxes[i, 3]
        hy = boxes[i, 4]
        qx = max(lx - hx, 0.0)
        qy = max(ly - hy, 0.0)
        dn = math.sqrt(qx * qx + qy * qy)
        df = math.sqrt((lx + hx) ** 2 + (ly + hy) ** 2)
        dmin[i] = dn
        if dn > max_range:
            continue
        cb = boxes[i, 5] - oz
        ct = boxes[i, 6] - oz
        if dn <= 0.0:
            mlo[i] = -INF if cb < 0.0 else cb / df
            mhi[i] = INF if ct >= 0.0 else ct / df
        else:
            mlo[i] = cb / df if cb >= 0.0 else cb / dn
            mhi[i] = ct / dn if ct >= 0.0 else ct / df
        mlo[i] -= 1e-9 * (1.0 + abs(mlo[i]))
        mhi[i] += 1e-9 * (1.0 + abs(mhi[i]))
        rc = math.sqrt(px * px + py * py)
        rad = math.sqrt(hx * hx + hy * hy)
        if rc <= rad * 1.000001 + 1e-9:
            alo[i] = -4.0 * math.pi  # all headings
            ahi[i] = 4.0 * math.pi
        else:
            th = math.atan2(-py, -px)
            dl = min(rad / math.sqrt(rc * rc - rad * rad), math.pi) + 1e-9  # tan(asin) >= asin
            alo[i] = th - dl
            ahi[i] = th + dl
    counts = np.zeros(nsec + 1, np.int64)
    for i in range(nb):
        if dmin[i] > max_range:
            continue
        q0 = int(math.floor(alo[i] / sec_w))
        q1 = min(int(math.floor(ahi[i] / sec_w)), q0 + nsec - 1)
        for q in range(q0, q1 + 1):
            counts[(q % nsec) + 1] += 1
    for q in range(nsec):
        counts[q + 1] += counts[q]
    nbinned = counts[nsec]
    fill = counts[:nsec].copy()
    bins = np.empty(counts[nsec], np.int64)
    for i in range(nb):
        if dmin[i] > max_range:
            continue
        q0 = int(math.floor(alo[i] / sec_w))
        q1 = min(int(math.floor(ahi[i] / sec_w)), q0 + nsec - 1)
        for q in range(q0, q1 + 1):
            qq = q % nsec
            bins[fill[qq]] = i
            fill[qq] += 1
    for q in range(nsec):  # sort each bin by dmin (insertion sort: bins are short)
        for e in range(counts[q] + 1, counts[q + 1]):
            i = bins[e]
            f = e - 1
            while f >= counts[q] and dmin[bins[f]] > dmin[i]:
                bins[f + 1] = bins[f]
                f -= 1
            bins[f + 1] = i
    # ---- columns: boxes over the terrain ranges ---------------------------------------
    if nbinned == 0:  # no box within range: the terrain ranges are the scan
        for k in range(nch):
            for a in range(naz):
                r = tr[k, a]
                out[k, a] = r if (min_range <= r <= max_range) else INF
        return
    stamp = np.full(nb, -1, np.int64)
    dirs = np.empty((nch, 3))
    slope = np.empty(nch)
    hxy = np.empty(nch)
    best = np.empty(nch)
    uwx, uwy, uwz = rot[0, 2], rot[1, 2], rot[2, 2]
    for a in range(naz):
        ca = cos_az[a]
        sa = sin_az[a]
        awx = rot[0, 0] * ca + rot[0, 1] * sa
        awy = rot[1, 0] * ca + rot[1, 1] * sa
        awz = rot[2, 0] * ca + rot[2, 1] * sa
        reach = 0.0
        for k in range(nch):
            ce = cos_el[k]
            se = sin_el[k]
            rx = ce * awx + se * uwx
            ry = ce * awy + se * uwy
            rz = ce * awz + se * uwz
            dirs[k, 0] = rx
            dirs[k, 1] = ry
            dirs[k, 2] = rz
            hh = math.sqrt(rx * rx + ry * ry)
            hxy[k] = hh
            slope[k] = rz / hh if hh > 0.0 else (INF if rz > 0.0 else -INF)
            best[k] = tr[k, a]
            reach = max(reach, min(best[k], max_range) * hh)
        # boxes: candidates from the sectors spanned by the column's headings, nearest first.
        # Headings vary monotonically with elevation (while no ray is vertical); slopes do for
        # moderate tilts: checked, else every sector and channel is a candidate (still exact).
        if nbinned > 0:  # (no box within range: nothing to do)
            ordered = hxy[0] > 1e-9
            for k in range(1, nch):
                if slope[k] < slope[k - 1] or hxy[k] <= 1e-9:
                    ordered = False
            if ordered:
                th0 = math.atan2(dirs[0, 1], dirs[0, 0])
                th1 = math.atan2(dirs[nch - 1, 1], dirs[nch - 1, 0])
                d = (th1 - th0 + math.pi) % TWO_PI - math.pi
                lo = min(th0, th0 + d) - 1e-9
                hi = max(th0, th0 + d) + 1e-9
                q0 = int(math.floor(lo / sec_w))
                q1 = int(math.floor(hi / sec_w))
            else:
                lo = -math.pi
                hi = 3.0 * math.pi
                q0 = 0
                q1 = nsec - 1
            for q in range(q0, q1 + 1):
                qq = q % nsec
                for e in range(counts[qq], counts[qq + 1]):
                    i = bins[e]
                    if dmin[i] > reach:
                        break
                    if stamp[i] == a:
                        continue
                    stamp[i] = a
                    # heading overlap of the box's interval with the column's
                    w0 = alo[i] - lo  # the box's heading interval, shifted to start in [lo, lo + 2 pi)
                    if w0 < 0.0:
                        w0 += TWO_PI
                        if w0 < 0.0:
                            w0 += TWO_PI
                    elif w0 >= TWO_PI:
                        w0 -= TWO_PI
                    if w0 > hi - lo and w0 + (ahi[i] - alo[i]) < TWO_PI:
                        continue
                    # channels whose world slope lies in [mlo, mhi] (slopes ascend with k)
                    if ordered:  # binary searches (written out: no array passed to a helper in the loop)
                        v = mlo[i]
                        lo_ = 0
                        hi_ = nch
                        while lo_ < hi_:
                            mid = (lo_ + hi_) >> 1
                            if slope[mid] < v:
                                lo_ = mid + 1
                            else:
                                hi_ = mid
                        k0 = lo_
                        v = math.nextafter(mhi[i], INF)
                        hi_ = nch
                        while lo_ < hi_:
                            mid = (lo_ + hi_) >> 1
                            if slope[mid] < v:
                                lo_ = mid + 1
                            else:
                                hi_ = mid
                        k1 = lo_ - 1
                    else:
                        k0 = 0
                        k1 = nch - 1
                    b0, b1, b3, b4 = boxes[i, 0], boxes[i, 1], boxes[i, 3], boxes[i, 4]
                    b5, b6, b7, b8 = boxes[i, 5], boxes[i, 6], boxes[i, 7], boxes[i, 8]
                    for k in range(k0, k1 + 1):
                        if dmin[i] > best[k] * hxy[k]:
                            continue
                        tb = _ray_box(Box(b0, b1, b7, b8, b3, b4, b5, b6),
                                      Ray(ox, oy, oz, dirs[k, 0], dirs[k, 1], dirs[k, 2]))
                        if tb < best[k]:
                            best[k] = tb
        for k in range(nch):
            r = best[k]
            out[k, a] = r if (min_range <= r <= max_range) else INF
