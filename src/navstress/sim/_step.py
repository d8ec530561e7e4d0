"""The compiled inner loop of :class:`~navstress.sim.simulation.Simulation`.

One numba call (:func:`run_steps`) runs physics steps until something needs Python: a lidar scan,
a collision or stop event, instability, full sample buffers or used-up pre-drawn random numbers,
or the requested step. Each step is the pending velocity command (when its step has come), the
drive firmware, the obstacle pool refill (every ``pool_every`` steps), the stages of MuJoCo's
``mj_fwdPosition`` up to ``mj_collision``, the skid-steer contact rewrite
(:func:`_align_wheel_contacts`; optionally analytic wheel contacts first), the remaining stages
(``mj_makeConstraint``, ``mj_transmission``, ``mj_projectConstraint``), ``mj_fwdVelocity``,
``mj_step2``, then the event checks; odometry, IMU, pose and observer readings are recorded in
buffers, IMU and pose noise from standard normals that Python pre-draws from the sensors'
generators in batches (Python turns the last rows into readings, see ``Simulation._flush``).

MuJoCo's C functions are called by symbol from the loaded ``libmujoco`` (numba intrinsics, so the
code caches), with the ``mjModel*``/``mjData*`` addresses of the Python objects. ``mjData.ncon``
and the ``mjContact`` array are read in place: their layout (MuJoCo 4.0: ``ncon`` right after
``timer``, 608-byte contacts) is checked against the Python bindings by :func:`check_layout`.
"""

from __future__ import annotations

import ctypes
import math
import glob
import os
from typing import Any

import llvmlite.binding as llvm
import llvmlite.ir as ir
import mujoco
import numba
import numpy as np
from numba import carray, types  # type: ignore[attr-defined]
from numba.core import cgutils
from numba.extending import intrinsic

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.errors import SimulationError
from navstress.sim.model import fill_obstacle_slots

_LIBS = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
if _LIBS:
    llvm.load_library_permanently(_LIBS[0])

# mjContact layout (bytes): size, pos, frame, friction, geom[2]
CON_SIZE, CON_POS, CON_FRAME, CON_FRICTION, CON_GEOM, CON_EXCLUDE, CON_EFC = 608, 8, 32, 112, 564, 596, 600
_CF, _CI = CON_SIZE // 8, CON_SIZE // 4  # contact stride in float64 / int32 units

# status bits returned by run_steps
DONE, LIDAR, CONTACT, LEFT_MAP, FLIPPED, UNSTABLE, FLUSH = 0, 1, 2, 4, 8, 16, 32
# sensor rows of the schedule arrays (the order in which sensors fire within a step)
ODOM, IMU, POSE, SCAN, OBSERVER = 0, 1, 2, 3, 4
NSENSORS = 5
# int state I[...]
# I_TOUCHING: size of the touching set; I_STARTS/I_NEVENT: contact starts / events not yet flushed;
# I_CMDK: step at which the pending command (F_CMDV, F_CMDW) takes effect (NO_CMD: none);
# I_NOISE: sensor noise on; I_NIMU/I_NPOSE: next unused value of the noise rows IMU_NOISE/POSE_NOISE
I_K, I_TOUCHING, I_NCONTACT, I_WARN0, I_JITTER, I_STARTS, I_NEVENT, I_CMDK, I_NOISE, I_NIMU, I_NPOSE = range(11)
NI = 11
NO_CMD = np.iinfo(np.int64).max
# rows of the pre-drawn standard-normal noise array (7 values per IMU sample, 6 per pose sample)
IMU_NOISE, POSE_NOISE = 0, 1
NOISE_BATCH = 42 * 16  # a multiple of 7 and 6: a row is used up exactly
# float state F[...] (drive firmware state and the constants of a run)
(F_TV, F_TW, F_V, F_W, F_YAWI, F_REF, F_DT, F_DV, F_DW, F_SKID, F_KP, F_KI, F_HALFTRACK, F_RADIUS, F_HOLD,
 F_MU, F_FLOOR, F_EPS, F_MAXSPEED, F_SX, F_SY, F_MARGIN, F_COSFLIP, F_RATEJIT, F_UPZ, F_DEBOUNCE) = (
    0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28)
# wheel odometry state: x, y, yaw, previous angles (4), previous t, v, omega, wheel radius, track
F_OX, F_OY, F_OYAW, F_OA, F_OT, F_OV, F_OW, F_OR, F_OTRACK = 29, 30, 31, 32, 36, 37, 38, 39, 40
# pending command (clamped); IMU yaw bias and last sample time; IMU and pose noise parameters
F_CMDV, F_CMDW, F_IBIAS, F_IT, F_IATT, F_IRATE, F_IDRIFT, F_PPOS, F_PATT = range(41, 50)
NF = 50


def _void_mj(name: str) -> Any:
    """A numba intrinsic calling ``void name(const mjModel*, mjData*)`` with two addresses."""

    @intrinsic
    def call(typingctx: Any, m: Any, d: Any) -> Any:  # pragma: no cover - compile time
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            ptr = ir.IntType(8).as_pointer()
            fn = cgutils.get_or_insert_function(  # type: ignore[no-untyped-call]
                builder.module, ir.FunctionType(ir.VoidType(), [ptr, ptr]), name)
            builder.call(fn, [builder.inttoptr(args[0], ptr), builder.inttoptr(args[1], ptr)])
            return context.get_dummy_value()

        return types.void(types.int64, types.int64), codegen

    return call


# mj_fwdPosition's stages, so that the contacts can be changed between collision and constraints
# (the composition is bit-identical to mj_fwdPosition in MuJoCo 4.0; checked by a test)
mj_kinematics = _void_mj("mj_kinematics")
mj_comPos = _void_mj("mj_comPos")
mj_camlight = _void_mj("mj_camlight")
mj_flex = _void_mj("mj_flex")
mj_tendon = _void_mj("mj_tendon")
mj_crb = _void_mj("mj_crb")
mj_factorM = _void_mj("mj_factorM")
mj_collision = _void_mj("mj_collision")
mj_transmission = _void_mj("mj_transmission")
mj_makeConstraint = _void_mj("mj_makeConstraint")
mj_projectConstraint = _void_mj("mj_projectConstraint")
mj_fwdVelocity = _void_mj("mj_fwdVelocity")
mj_step2 = _void_mj("mj_step2")


def _add_contact(typingctx: Any, m: Any, d: Any, con: Any) -> Any:  # pragma: no cover - compile time
    """``int mj_addContact(const mjModel*, mjData*, const mjContact*)`` with three addresses."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        ptr = ir.IntType(8).as_pointer()
        fn = cgutils.get_or_insert_function(  # type: ignore[no-untyped-call]
            builder.module, ir.FunctionType(ir.IntType(32), [ptr, ptr, ptr]), "mj_addContact")
        r = builder.call(fn, [builder.inttoptr(a, ptr) for a in args])
        return builder.sext(r, ir.IntType(64))

    return types.int64(types.int64, types.int64, types.int64), codegen


mj_addContact: Any = intrinsic(_add_contact)


def _ptr(dtype: Any) -> Any:
    @intrinsic
    def cast(typingctx: Any, addr: Any) -> Any:  # pragma: no cover - compile time
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            ty = context.get_value_type(types.CPointer(dtype))  # type: ignore[no-untyped-call]
            return builder.inttoptr(args[0], ty)

        return types.CPointer(dtype)(types.int64), codegen  # type: ignore[no-untyped-call]

    return cast


_f64ptr = _ptr(types.float64)
_i32ptr = _ptr(types.int32)
_i64ptr = _ptr(types.int64)


@numba.njit(cache=True)
def _read_ptr(addr: int) -> int:  # pragma: no cover - compiled
    return int(carray(_i64ptr(addr), (1,))[0])


def ncon_address(d: mujoco.MjData) -> int:
    """Address of ``d->ncon`` (the int right after the ``timer`` array)."""
    td = d.timer.duration
    return int(td.ctypes.data + td.shape[0] * td.strides[0])


def contact_field_address(d: mujoco.MjData) -> int:
    """Address of the pointer field ``d->contact``: mjData's 100th pointer field after ``qpos``
    (``mujoco.introspect`` checks that), found by locating the ``qpos`` field's value."""
    from mujoco.introspect import structs

    names = [f.name for f in structs.STRUCTS["mjData"].fields]
    gap = names.index("contact") - names.index("qpos")
    base = ncon_address(d)
    words = np.ctypeslib.as_array((ctypes.c_uint64 * 1024).from_address(base))
    # the qpos value must be followed, at their offsets, by the addresses of the other arrays
    # that mjData exposes (a lone qpos/qvel pair can also occur elsewhere in memory by chance,
    # and the ``buffer`` field before it holds the same address as qpos)
    q = names.index("qpos")
    checks = [(names.index(f) - q, getattr(d, f).ctypes.data) for f in
              ("qvel", "qacc_warmstart", "ctrl", "qfrc_applied", "xfrc_applied", "mocap_pos")
              if f in names and getattr(d, f).size > 0]
    hits = [h for h in np.flatnonzero(words == d.qpos.ctypes.data)
            if all(h + off < len(words) and words[h + off] == addr for off, addr in checks)]
    if len(hits) != 1:
        raise SimulationError(f"MuJoCo {mujoco.__version__}: cannot locate mjData.qpos ({len(hits)} candidates)")
    return int(base + 8 * (int(hits[0]) + gap))


@numba.njit(cache=True)
def _read_ncon(addr: int) -> int:  # pragma: no cover - compiled
    return int(carray(_i32ptr(addr), (1,))[0])


@numba.njit(cache=True)
def _read_contacts(addr: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    cf = carray(_f64ptr(addr), (n * _CF,))
    ci = carray(_i32ptr(addr), (n * _CI,))
    pos, frame, fr, geom = np.zeros((n, 3)), np.zeros((n, 9)), np.zeros((n, 5)), np.zeros((n, 2), np.int64)
    for i in range(n):
        for a in range(3):
            pos[i, a] = cf[i * _CF + CON_POS // 8 + a]
        for a in range(9):
            frame[i, a] = cf[i * _CF + CON_FRAME // 8 + a]
        for a in range(5):
            fr[i, a] = cf[i * _CF + CON_FRICTION // 8 + a]
        for a in range(2):
            geom[i, a] = ci[i * _CI + CON_GEOM // 4 + a]
    return pos, frame, fr, geom


_LAYOUT_OK: list[bool] = []


def check_layout() -> None:
    """Check the raw ``ncon``/``mjContact`` reads against the Python bindings on a small model."""
    if _LAYOUT_OK:
        return
    if not _LIBS:
        raise SimulationError(f"libmujoco not found beside {mujoco.__file__}")
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="5 5 1"/><body pos="0.1 0.2 0.09" euler="0 0 0.3">'
        '<freejoint/><geom type="box" size=".1 .2 .1"/></body></worldbody></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    c = d.contact
    ok = d.ncon == 4 and _read_ncon(ncon_address(d)) == d.ncon and c.dist.strides[0] == CON_SIZE
    if ok:
        ok = _read_ptr(contact_field_address(d)) == c.dist.ctypes.data
        pos, frame, fr, geom = _read_contacts(_read_ptr(contact_field_address(d)), d.ncon)
        ok = ok and (np.array_equal(pos, c.pos) and np.array_equal(frame, c.frame) and np.array_equal(fr, c.friction)
              and np.array_equal(geom, c.geom))
    if not ok:
        raise SimulationError(f"MuJoCo {mujoco.__version__}: unexpected mjData/mjContact memory layout "
                              "(navstress.sim._step assumes MuJoCo 4.0's)")
    _LAYOUT_OK.append(True)


def contact_template(m: mujoco.MjModel, d0: mujoco.MjData, wheel_geoms: np.ndarray, chassis_qpos: int) -> np.ndarray:
    """The raw bytes (as 76 float64) of a wheel-ground contact as MuJoCo's collision makes it
    (solref, solimp, friction mixing, dim ...): the chassis of a scratch copy of ``d0`` is lowered
    until a wheel touches the ground."""
    d = mujoco.MjData(m)
    d.qpos[:] = d0.qpos
    d.mocap_pos[:] = d0.mocap_pos
    wheels = set(int(g) for g in wheel_geoms)
    for drop in np.arange(0.0, 2.0, 0.01):
        d.qpos[chassis_qpos + 2] = d0.qpos[chassis_qpos + 2] - drop
        mujoco.mj_forward(m, d)
        for i in range(d.ncon):
            if int(d.contact.geom[i, 0]) in wheels or int(d.contact.geom[i, 1]) in wheels:
                base = _read_ptr(contact_field_address(d)) + i * CON_SIZE
                return np.ctypeslib.as_array((ctypes.c_double * _CF).from_address(base)).copy()
    raise SimulationError("no wheel-ground contact found to copy contact parameters from")


@numba.njit(cache=True)
def _add_wheel_contacts(maddr: int, daddr: int, xpos: np.ndarray, wbody: np.ndarray, wgeom: np.ndarray,
                        terrain: int, hf: np.ndarray, grid: np.ndarray, tmpl: np.ndarray,
                        cbuf: np.ndarray) -> int:  # pragma: no cover - compiled
    """Add every wheel's sphere-terrain contacts (:func:`sphere_terrain_contacts`) to MuJoCo's
    contact list, copying ``tmpl`` (a MuJoCo wheel-ground contact) for the other fields."""
    ti = tmpl.view(np.int32)
    added = 0
    for w in range(wgeom.shape[0]):  # no wheel geoms given: MuJoCo's collision makes the contacts
        b = wbody[w]
        nc = sphere_terrain_contacts(xpos[b, 0], xpos[b, 1], xpos[b, 2], grid[4], hf, grid[0], grid[1], grid[2],
                                     grid[3], cbuf)
        for k in range(nc):
            nx, ny, nz = cbuf[k, 4], cbuf[k, 5], cbuf[k, 6]
            tmpl[0] = cbuf[k, 0]
            tmpl[1], tmpl[2], tmpl[3] = cbuf[k, 1], cbuf[k, 2], cbuf[k, 3]
            # frame: normal, then any orthonormal tangents (the skid-steer rewrite turns them)
            if abs(nz) < 0.9:
                tx, ty, tz = ny, -nx, 0.0
            else:
                tx, ty, tz = 0.0, nz, -ny
            ln = (tx * tx + ty * ty + tz * tz) ** 0.5
            tx, ty, tz = tx / ln, ty / ln, tz / ln
            f = CON_FRAME // 8
            tmpl[f], tmpl[f + 1], tmpl[f + 2] = nx, ny, nz
            tmpl[f + 3], tmpl[f + 4], tmpl[f + 5] = tx, ty, tz
            tmpl[f + 6], tmpl[f + 7], tmpl[f + 8] = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
            g = CON_GEOM // 4
            ti[g - 2], ti[g - 1], ti[g], ti[g + 1] = terrain, wgeom[w], terrain, wgeom[w]
            ti[CON_EFC // 4] = -1
            ti[CON_EXCLUDE // 4] = 0
            if mj_addContact(maddr, daddr, tmpl.ctypes.data) == 0:
                added += 1
    return added


@numba.njit(cache=True)
def _align_wheel_contacts(cf: np.ndarray, ci: np.ndarray, n: int, wheel_of_geom: np.ndarray, qvel: np.ndarray,
                          cm: np.ndarray, cpos: np.ndarray, xpos: np.ndarray, wbody: np.ndarray,
                          wdof: np.ndarray, mu: float, floor: float, eps: float) -> int:  # pragma: no cover
    """Turn wheel contact frames to (normal, rolling, lateral) and split ``mu`` by slip direction.

    ``cf``/``ci``: the contact array as float64/int32. The pyramidal limits become
    ``mu*|s_roll|/|s|`` and ``mu*|s_lat|/|s|`` (at least ``floor*mu``; full ``mu`` both ways when
    ``|s| << eps``), with ``s`` the wheel's slip velocity at the contact at the start of the step:
    Coulomb friction opposing the slip, one step late. Returns the number of contacts changed.
    """
    k = 0
    ax, ay, az = cm[1], cm[4], cm[7]  # wheel axle = chassis y axis
    wx = cm[0] * qvel[3] + cm[1] * qvel[4] + cm[2] * qvel[5]
    wy = cm[3] * qvel[3] + cm[4] * qvel[4] + cm[5] * qvel[5]
    wz = cm[6] * qvel[3] + cm[7] * qvel[4] + cm[8] * qvel[5]
    gi, pi, fi, ri = CON_GEOM // 4, CON_POS // 8, CON_FRAME // 8, CON_FRICTION // 8
    for i in range(n):
        w = wheel_of_geom[ci[i * _CI + gi]]
        if w < 0:
            w = wheel_of_geom[ci[i * _CI + gi + 1]]
        if w < 0:
            continue
        f0 = i * _CF + fi
        nx, ny, nz = cf[f0], cf[f0 + 1], cf[f0 + 2]
        tx = ay * nz - az * ny
        ty = az * nx - ax * nz
        tz = ax * ny - ay * nx
        s = (tx * tx + ty * ty + tz * tz) ** 0.5
        if s < 1e-6:
            continue
        tx /= s
        ty /= s
        tz /= s
        ux = ny * tz - nz * ty
        uy = nz * tx - nx * tz
        uz = nx * ty - ny * tx
        cf[f0 + 3] = tx
        cf[f0 + 4] = ty
        cf[f0 + 5] = tz
        cf[f0 + 6] = ux
        cf[f0 + 7] = uy
        cf[f0 + 8] = uz
        spin = qvel[wdof[w]]
        p0 = i * _CF + pi
        px, py, pz = cf[p0], cf[p0 + 1], cf[p0 + 2]
        rx, ry, rz = px - cpos[0], py - cpos[1], pz - cpos[2]
        vx = qvel[0] + wy * rz - wz * ry
        vy = qvel[1] + wz * rx - wx * rz
        vz = qvel[2] + wx * ry - wy * rx
        b = wbody[w]
        qx, qy, qz = px - xpos[b, 0], py - xpos[b, 1], pz - xpos[b, 2]
        vx += spin * (ay * qz - az * qy)
        vy += spin * (az * qx - ax * qz)
        vz += spin * (ax * qy - ay * qx)
        sl = vx * tx + vy * ty + vz * tz
        st = vx * ux + vy * uy + vz * uz
        mag = (sl * sl + st * st + eps * eps) ** 0.5
        e = eps / mag
        cf[i * _CF + ri] = mu * max(abs(sl) / mag, e, floor)
        cf[i * _CF + ri + 1] = mu * max(abs(st) / mag, e, floor)
        k += 1
    return k


@numba.njit(cache=True)
def fwd_position_collision(maddr: int, daddr: int) -> None:  # pragma: no cover - compiled
    """First part of ``mj_fwdPosition``: kinematics, inertia, factorisation, collision."""
    mj_kinematics(maddr, daddr)
    mj_comPos(maddr, daddr)
    mj_camlight(maddr, daddr)
    mj_flex(maddr, daddr)
    mj_tendon(maddr, daddr)
    mj_crb(maddr, daddr)
    mj_factorM(maddr, daddr)
    mj_collision(maddr, daddr)


@numba.njit(cache=True)
def fwd_position_constraints(maddr: int, daddr: int) -> None:  # pragma: no cover - compiled
    """Rest of ``mj_fwdPosition`` (without constraint islands: the model disables them)."""
    mj_makeConstraint(maddr, daddr)
    mj_transmission(maddr, daddr)
    mj_projectConstraint(maddr, daddr)


@numba.njit(cache=True)
def _closest_on_triangle(px: float, py: float, pz: float, a: np.ndarray, b: np.ndarray,
                         c: np.ndarray) -> tuple[float, float, float, bool]:  # pragma: no cover - compiled
    """Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5) and
    whether it lies in the triangle's interior (a face contact) rather than on an edge/vertex."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = px - a[0], py - a[1], pz - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return a[0], a[1], a[2], False
    bpx, bpy, bpz = px - b[0], py - b[1], pz - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return b[0], b[1], b[2], False
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return a[0] + v * abx, a[1] + v * aby, a[2] + v * abz, False
    cpx, cpy, cpz = px - c[0], py - c[1], pz - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return c[0], c[1], c[2], False
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return a[0] + w * acx, a[1] + w * acy, a[2] + w * acz, False
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2]), False
    den = 1.0 / (va + vb + vc)
    v = vb * den
    w = vc * den
    return a[0] + abx * v + acx * w, a[1] + aby * v + acy * w, a[2] + abz * v + acz * w, True


@numba.njit(cache=True)
def sphere_terrain_contacts(cx: float, cy: float, cz: float, r: float, hf: np.ndarray, x0: float, y0: float,
                            dx: float, dy: float, out: np.ndarray) -> int:  # pragma: no cover - compiled
    """Contacts of a sphere (centre c, radius r) with the triangulated heightfield ``hf[i, j]`` at
    (x0 + j*dx, y0 + i*dy), cells split along the (i, j)-(i+1, j+1) diagonal (MuJoCo's hfield).

    Writes rows (dist < 0, pos x3 on the midway surface, normal x3 from the ground to the sphere)
    into ``out`` and returns how many (at most ``out.shape[0]``). Exact sphere-mesh geometry: every
    triangle whose interior holds the closest point to the centre is a face contact (a valley
    gives two) and, when the deepest point of the whole surface lies on an edge or vertex (a
    ridge), that point with the normal towards the centre; other edge points (e.g. the borders of
    coplanar neighbours) are not contacts. Coincident face points count once; with more than
    ``out.shape[0]`` contacts the deepest are kept.
    """
    rows, cols = hf.shape
    j0 = max(int(np.floor((cx - r - x0) / dx)), 0)
    j1 = min(int(np.floor((cx + r - x0) / dx)), cols - 2)
    i0 = max(int(np.floor((cy - r - y0) / dy)), 0)
    i1 = min(int(np.floor((cy + r - y0) / dy)), rows - 2)
    a, b, c = np.empty(3), np.empty(3), np.empty(3)
    nface = 0
    best = 0.0  # deepest penetration over all triangles
    best_is_edge = False
    ex = ey = ez = 0.0
    cap = out.shape[0]
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            h00, h01, h10, h11 = hf[i, j], hf[i, j + 1], hf[i + 1, j], hf[i + 1, j + 1]
            if cz - r >= max(max(h00, h01), max(h10, h11)):
                continue
            xa, xb, ya, yb = x0 + j * dx, x0 + (j + 1) * dx, y0 + i * dy, y0 + (i + 1) * dy
            for tri in range(2):
                a[0], a[1], a[2] = xa, ya, h00
                c[0], c[1], c[2] = xb, yb, h11
                if tri == 0:  # (i,j) (i,j+1) (i+1,j+1)
                    b[0], b[1], b[2] = xb, ya, h01
                else:  # (i,j) (i+1,j+1) (i+1,j)
                    b[0], b[1], b[2] = c[0], c[1], c[2]
                    c[0], c[1], c[2] = xa, yb, h10
                qx, qy, qz, inside = _closest_on_triangle(cx, cy, cz, a, b, c)
                if inside:
                    # a centre behind this face's plane (a steep neighbouring face) cannot have its
                    # closest surface point inside the face: judge that point by its distance alone
                    fx = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
                    fy = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
                    fz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                    inside = (cx - qx) * fx + (cy - qy) * fy + (cz - qz) * fz >= 0.0
                if not inside:  # edge/vertex point: a candidate only as the deepest point of all
                    ddx, ddy, ddz = cx - qx, cy - qy, cz - qz
                    pen = r - (ddx * ddx + ddy * ddy + ddz * ddz) ** 0.5
                    if pen > best:
                        best, best_is_edge = pen, True
                        ex, ey, ez = qx, qy, qz
                    continue
                # face point: upward face normal, penetration along it
                nx = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
                ny = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
                nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                ln = (nx * nx + ny * ny + nz * nz) ** 0.5
                nx, ny, nz = nx / ln, ny / ln, nz / ln
                dist = (cx - qx) * nx + (cy - qy) * ny + (cz - qz) * nz - r
                if dist >= 0.0:
                    continue
                if -dist >= best:
                    best, best_is_edge = -dist, False
                dup = False
                for k in range(nface):
                    dup = dup or (abs(out[k, 1] - qx) + abs(out[k, 2] - qy) < 1e-6 and
                                  abs(out[k, 4] - nx) + abs(out[k, 5] - ny) < 1e-6)
                if dup:
                    continue
                k = nface
                if nface == cap:  # full: replace the shallowest if this one is deeper
                    k = 0
                    for kk in range(1, cap):
                        if out[kk, 0] > out[k, 0]:
                            k = kk
                    if out[k, 0] <= dist:
                        continue
                else:
                    nface += 1
                out[k, 0] = dist
                out[k, 1], out[k, 2], out[k, 3] = qx, qy, qz
                out[k, 4], out[k, 5], out[k, 6] = nx, ny, nz
    if best_is_edge:  # the deepest point is on an edge or vertex (a ridge): it is a contact too
        ddx, ddy, ddz = cx - ex, cy - ey, cz - ez
        ln = (ddx * ddx + ddy * ddy + ddz * ddz) ** 0.5
        if ln > 1e-9:
            k = nface if nface < cap else cap - 1
            out[k, 0] = -best
            out[k, 1], out[k, 2], out[k, 3] = ex, ey, ez
            out[k, 4], out[k, 5], out[k, 6] = ddx / ln, ddy / ln, ddz / ln
            nface = k + 1
    for k in range(nface):  # MuJoCo's contact position: midway between the two surfaces
        for a_ in range(3):
            out[k, 1 + a_] += 0.5 * out[k, 0] * out[k, 4 + a_]
    return nface


@numba.njit(cache=True)
def _drive(F: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray,
           wqpos: np.ndarray) -> None:  # pragma: no cover - compiled
    """Robot firmware: ramp to the acceleration limits, yaw-rate PI on the gyro, wheel-angle hold.

    Each wheel tracks the integral of its speed command (bounded lag 0.5 rad), so a stopped
    robot holds on a slope instead of creeping at torque / kv."""
    dt = F[F_DT]
    F[F_V] += min(max(F[F_TV] - F[F_V], -F[F_DV]), F[F_DV])
    F[F_W] += min(max(F[F_TW] - F[F_W], -F[F_DW]), F[F_DW])
    err = F[F_W] - qvel[5]  # free joint: body-frame angular velocity
    F[F_YAWI] = min(max(F[F_YAWI] + err * dt, -0.5), 0.5)
    dw_cmd = F[F_SKID] * F[F_W] + F[F_KP] * err + F[F_KI] * F[F_YAWI]
    left = (F[F_V] - dw_cmd * F[F_HALFTRACK]) / F[F_RADIUS]
    right = (F[F_V] + dw_cmd * F[F_HALFTRACK]) / F[F_RADIUS]
    for i in range(4):
        cmd = left if i < 2 else right
        a = qpos[wqpos[i]]
        e = min(max(F[F_REF + i] + cmd * dt - a, -0.5), 0.5)
        F[F_REF + i] = a + e
        ctrl[i] = cmd + F[F_HOLD] * e


@numba.njit(cache=True)
def odom_update(F: np.ndarray, a0: float, a1: float, a2: float, a3: float, t: float) -> None:  # pragma: no cover
    """:meth:`navstress.sim.sensors.WheelOdometry.update` on the state in ``F`` (same arithmetic):
    wheel angles FL, RL, FR, RR at time ``t``; exact-arc integration."""
    d0, d1, d2, d3 = a0 - F[F_OA], a1 - F[F_OA + 1], a2 - F[F_OA + 2], a3 - F[F_OA + 3]
    F[F_OA], F[F_OA + 1], F[F_OA + 2], F[F_OA + 3] = a0, a1, a2, a3
    r = F[F_OR]
    dl = r * 0.5 * (d0 + d1)
    dr = r * 0.5 * (d2 + d3)
    ds = 0.5 * (dl + dr)
    dth = (dr - dl) / F[F_OTRACK]
    yaw = F[F_OYAW]
    if abs(dth) > 1e-9:
        k = ds / dth
        F[F_OX] += k * (math.sin(yaw + dth) - math.sin(yaw))
        F[F_OY] += k * (math.cos(yaw) - math.cos(yaw + dth))
    else:
        F[F_OX] += ds * math.cos(yaw)
        F[F_OY] += ds * math.sin(yaw)
    F[F_OYAW] = (yaw + dth + math.pi) % (2 * math.pi) - math.pi
    dt = t - F[F_OT]
    F[F_OT] = t
    if dt > 0:
        F[F_OV], F[F_OW] = ds / dt, dth / dt


@numba.njit(cache=True)
def _euler(qpos: np.ndarray) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """(yaw, pitch, roll), Z-Y-X, of the chassis quaternion qpos[3:7] (as ``euler_from_mat``)."""
    w, x, y, z = qpos[3], qpos[4], qpos[5], qpos[6]
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r10 = 2.0 * (x * y + w * z)
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    return np.arctan2(r10, r00), np.arcsin(max(-1.0, min(1.0, -r20))), np.arctan2(r21, r22)


@numba.njit(cache=True)
def _wrap(a: float) -> float:  # pragma: no cover - compiled
    """:func:`navstress.sim.sensors.wrap` (same arithmetic: Python's float modulo)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@numba.njit(cache=True)
def _fire(k: int, I: np.ndarray, F: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, wqpos: np.ndarray,
          next_k: np.ndarray, period: np.ndarray, jit: np.ndarray, jit_idx: np.ndarray, samples: np.ndarray,
          nsamp: np.ndarray, noise: np.ndarray) -> int:  # pragma: no cover - compiled
    """Record the readings of the sensors due at step ``k``; LIDAR when the lidar is due (its
    schedule already advanced), FLUSH when a buffer is full or a noise/jitter row used up
    (nothing recorded for that sensor).

    Rows: odometry (t, x, y, yaw, v, omega); IMU (t, roll, pitch, yaw, wx, wy, wz) and pose
    (t, x, y, z, yaw, pitch, roll) with their noise, as ``ImuSensor.read``/``PoseSensor.read``
    compute it from the same standard normals (``noise``, pre-drawn in order); observer
    (t, x, y, z, yaw, pitch, roll), true."""
    status = DONE
    t = k * F[F_DT]
    noisy = I[I_NOISE] != 0
    nb = noise.shape[1]
    for s in range(NSENSORS):
        if next_k[s] > k:
            continue
        jittered = I[I_JITTER] != 0 and F[F_RATEJIT] > 0 and s != OBSERVER
        if (s != SCAN and nsamp[s] >= samples.shape[1]) or (jittered and jit_idx[s] >= jit.shape[1]):
            return status | FLUSH
        if noisy and ((s == IMU and I[I_NIMU] + 7 > nb) or (s == POSE and I[I_NPOSE] + 6 > nb)):
            return status | FLUSH
        if s == SCAN:
            status |= LIDAR
        else:
            row = samples[s, nsamp[s]]
            row[0] = t
            if s == ODOM:  # integrated here; the row is the reading (t, x, y, yaw, v, omega)
                odom_update(F, qpos[wqpos[0]], qpos[wqpos[1]], qpos[wqpos[2]], qpos[wqpos[3]], t)
                row[1], row[2], row[3], row[4], row[5] = F[F_OX], F[F_OY], F[F_OYAW], F[F_OV], F[F_OW]
            else:
                yaw, pitch, roll = _euler(qpos)
                if s == IMU:
                    wx, wy, wz = qvel[3], qvel[4], qvel[5]
                    if noisy:  # ImuSensor.read: bias random walk, white noise
                        j = I[I_NIMU]
                        e = noise[IMU_NOISE]
                        F[F_IBIAS] += F[F_IDRIFT] * math.sqrt(max(t - F[F_IT], 0.0)) * e[j]
                        a, rs = F[F_IATT], F[F_IRATE]
                        row[1], row[2] = roll + a * e[j + 1], pitch + a * e[j + 2]
                        row[3] = _wrap(yaw + F[F_IBIAS] + a * e[j + 3])
                        row[4], row[5], row[6] = wx + rs * e[j + 4], wy + rs * e[j + 5], wz + rs * e[j + 6]
                        I[I_NIMU] = j + 7
                    else:
                        row[1], row[2], row[3], row[4], row[5], row[6] = roll, pitch, yaw, wx, wy, wz
                    F[F_IT] = t
                elif s == POSE and noisy:  # PoseSensor.read: independent Gaussian noise
                    j = I[I_NPOSE]
                    e = noise[POSE_NOISE]
                    p, a = F[F_PPOS], F[F_PATT]
                    row[1], row[2], row[3] = qpos[0] + p * e[j], qpos[1] + p * e[j + 1], qpos[2] + p * e[j + 2]
                    row[4], row[5], row[6] = _wrap(yaw + a * e[j + 3]), pitch + a * e[j + 4], roll + a * e[j + 5]
                    I[I_NPOSE] = j + 6
                else:  # pose without noise, observer
                    row[1], row[2], row[3], row[4], row[5], row[6] = qpos[0], qpos[1], qpos[2], yaw, pitch, roll
            nsamp[s] += 1
        p = period[s]
        if jittered:
            p *= 1.0 + F[F_RATEJIT] * (2.0 * jit[s, jit_idx[s]] - 1.0)
            jit_idx[s] += 1
        next_k[s] = k + max(1, int(np.rint(p / F[F_DT])))
    return status


@numba.njit(cache=True)
def contact_events(t: float, x: float, y: float, cur: np.ndarray, ncur: int, prev: np.ndarray, I: np.ndarray,
                   last_touch: np.ndarray, debounce: float, events: np.ndarray) -> bool:  # pragma: no cover
    """:meth:`Observer.contacts` on arrays: ``cur[:ncur]`` (distinct obstacle indices) is the
    touching set after the step at ``t``, ``prev[:I[I_TOUCHING]]`` the previous one. A newly
    touched obstacle counts a start (``I[I_STARTS]``) and, when last touched more than
    ``debounce`` ago (``last_touch``, -inf: never), appends a collision event (t, x, y, obstacle)
    to ``events`` (``I[I_NEVENT]`` rows). Returns False when ``events`` is now full."""
    for i in range(ncur):
        o = cur[i]
        new = True
        for j in range(I[I_TOUCHING]):
            if prev[j] == o:
                new = False
                break
        if new:
            I[I_STARTS] += 1
            if t - last_touch[o] > debounce:
                e = I[I_NEVENT]
                events[e, 0], events[e, 1], events[e, 2], events[e, 3] = t, x, y, o
                I[I_NEVENT] = e + 1
        last_touch[o] = t
    for i in range(ncur):
        prev[i] = cur[i]
    I[I_TOUCHING] = ncur
    return bool(I[I_NEVENT] + ncur < events.shape[0])


@numba.njit(cache=True)
def run_steps(maddr: int, daddr: int, ncon_addr: int, con_field: int, k_stop: int, I: np.ndarray, F: np.ndarray,
              qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray, xpos: np.ndarray, xmat: np.ndarray,
              warn: np.ndarray, bad_warn: np.ndarray, bodies: np.ndarray, wqpos: np.ndarray, wdof: np.ndarray,
              wheel_of_geom: np.ndarray, obstacle_of_geom: np.ndarray, contact_out: np.ndarray,
              contact_prev: np.ndarray, last_touch: np.ndarray, events: np.ndarray,
              pool_every: int, pc: np.ndarray, ph: np.ndarray, pq: np.ndarray, preach: np.ndarray,
              pdist: np.ndarray, slot_obstacle: np.ndarray, slot_geom: np.ndarray, slot_mocap: np.ndarray,
              slot_bvh: np.ndarray, mocap_pos: np.ndarray, mocap_quat: np.ndarray, geom_size: np.ndarray,
              geom_rbound: np.ndarray, geom_aabb: np.ndarray, bvh_aabb: np.ndarray, geom_contype: np.ndarray,
              contype: int, park_z: float, next_k: np.ndarray, period: np.ndarray, jit: np.ndarray,
              jit_idx: np.ndarray, samples: np.ndarray, nsamp: np.ndarray, noise: np.ndarray, wgeom: np.ndarray,
              terrain: int, hf: np.ndarray, grid: np.ndarray, tmpl: np.ndarray,
              cbuf: np.ndarray) -> int:  # pragma: no cover
    """Fire the sensors due at the current step, then step until ``k_stop`` (or an event).

    ``bodies`` = (chassis, bumper geom, wheel bodies x4). Returns the status bits; the step count
    is ``I[I_K]``. The pending command (``I[I_CMDK]``) is applied at the start of its step. Bumper contacts go through :func:`contact_events` (collision events in
    ``events[:I[I_NEVENT]]``, contact starts counted in ``I[I_STARTS]``); FLUSH also when the event
    buffer is full. The up-vector z is in ``F[F_UPZ]``.
    """
    chassis, bumper = bodies[0], bodies[1]
    wbody = bodies[2:6]
    while True:
        k = I[I_K]
        st = _fire(k, I, F, qpos, qvel, wqpos, next_k, period, jit, jit_idx, samples, nsamp, noise)
        if st != DONE or k >= k_stop:
            return st
        # ---- one physics step
        if k >= I[I_CMDK]:  # the pending command takes effect at the start of its step
            F[F_TV], F[F_TW] = F[F_CMDV], F[F_CMDW]
            I[I_CMDK] = NO_CMD
        _drive(F, qpos, qvel, ctrl, wqpos)
        if pool_every > 0 and k % pool_every == 0:
            fill_obstacle_slots(qpos[0], qpos[1], pc, ph, pq, preach, pdist, slot_obstacle, slot_geom, slot_mocap,
                                slot_bvh, obstacle_of_geom, mocap_pos, mocap_quat, geom_size, geom_rbound,
                                geom_aabb, bvh_aabb, geom_contype, park_z, contype)
        fwd_position_collision(maddr, daddr)
        _add_wheel_contacts(maddr, daddr, xpos, wbody, wgeom, terrain, hf, grid, tmpl, cbuf)
        n = _read_ncon(ncon_addr)
        con_addr = _read_ptr(con_field)
        cf = carray(_f64ptr(con_addr), (n * _CF,))
        ci = carray(_i32ptr(con_addr), (n * _CI,))
        if n > 0:
            _align_wheel_contacts(cf, ci, n, wheel_of_geom, qvel, xmat[chassis], xpos[chassis], xpos, wbody, wdof,
                                  F[F_MU], F[F_FLOOR], F[F_EPS])
        fwd_position_constraints(maddr, daddr)
        mj_fwdVelocity(maddr, daddr)
        mj_step2(maddr, daddr)
        k += 1
        I[I_K] = k
        # ---- checks after the step
        sp = abs(qvel[0]) + abs(qvel[1]) + abs(qvel[2])
        if not sp < F[F_MAXSPEED]:
            return UNSTABLE
        if k % 50 == 0:
            tot = 0
            for w in bad_warn:
                tot += warn[w]
            if tot != I[I_WARN0]:
                return UNSTABLE
        status = DONE
        n = _read_ncon(ncon_addr)
        con_addr = _read_ptr(con_field)
        ci = carray(_i32ptr(con_addr), (n * _CI,))
        nk = 0
        gi = CON_GEOM // 4
        for i in range(n):
            g0, g1 = ci[i * _CI + gi], ci[i * _CI + gi + 1]
            o = -1
            if g0 == bumper:
                o = obstacle_of_geom[g1]
            elif g1 == bumper:
                o = obstacle_of_geom[g0]
            if o >= 0 and nk < contact_out.shape[0]:
                for j in range(nk):
                    if contact_out[j] == o:
                        o = -1
                        break
                if o >= 0:
                    contact_out[nk] = o
                    nk += 1
        I[I_NCONTACT] = nk
        if nk > 0 or I[I_TOUCHING] > 0:
            if not contact_events(k * F[F_DT], qpos[0], qpos[1], contact_out, nk, contact_prev, I, last_touch,
                                  F[F_DEBOUNCE], events):
                status |= FLUSH  # event buffer full: Python empties it before the next step
        x, y = qpos[0], qpos[1]
        mg = F[F_MARGIN]
        if not (mg <= x <= F[F_SX] - mg and mg <= y <= F[F_SY] - mg):
            status |= LEFT_MAP
        qw, qx, qy, qz = qpos[3], qpos[4], qpos[5], qpos[6]
        up_z = 1.0 - 2.0 * (qx * qx + qy * qy) / (qw * qw + qx * qx + qy * qy + qz * qz)
        F[F_UPZ] = up_z
        if up_z < F[F_COSFLIP]:
            status |= FLIPPED
        if status != DONE:
            return status
