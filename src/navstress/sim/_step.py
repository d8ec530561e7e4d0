"""The compiled inner loop of :class:`~navstress.sim.simulation.Simulation`.

One numba call (:func:`run_steps`) runs physics steps until something needs Python: a lidar scan,
a collision or stop event, instability, full sample buffers, or the requested step. Each step is
the drive firmware, the obstacle pool refill (every ``pool_every`` steps), MuJoCo's
``mj_fwdPosition``, the skid-steer contact rewrite (:func:`_align_wheel_contacts`) with
``mj_makeConstraint`` + ``mj_projectConstraint`` again when contacts changed, ``mj_fwdVelocity``,
``mj_step2``, then the event checks; odometry, IMU, pose and observer samples are recorded raw
(Python turns them into readings, with noise, in order, see ``Simulation._flush``).

MuJoCo's C functions are called by symbol from the loaded ``libmujoco`` (numba intrinsics, so the
code caches), with the ``mjModel*``/``mjData*`` addresses of the Python objects. ``mjData.ncon``
and the ``mjContact`` array are read in place: their layout (MuJoCo 4.0: ``ncon`` right after
``timer``, 608-byte contacts) is checked against the Python bindings by :func:`check_layout`.
"""

from __future__ import annotations

import ctypes
import glob
import os
from typing import Any

import llvmlite.binding as llvm
import llvmlite.ir as ir
import mujoco
import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from navstress.errors import SimulationError
from navstress.sim.model import fill_obstacle_slots

_LIBS = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
if _LIBS:
    llvm.load_library_permanently(_LIBS[0])

# mjContact layout (bytes): size, pos, frame, friction, geom[2]
CON_SIZE, CON_POS, CON_FRAME, CON_FRICTION, CON_GEOM = 608, 8, 32, 112, 564
_CF, _CI = CON_SIZE // 8, CON_SIZE // 4  # contact stride in float64 / int32 units

# status bits returned by run_steps
DONE, LIDAR, CONTACT, LEFT_MAP, FLIPPED, UNSTABLE, FLUSH = 0, 1, 2, 4, 8, 16, 32
# sensor rows of the schedule arrays (the order in which sensors fire within a step)
ODOM, IMU, POSE, SCAN, OBSERVER = 0, 1, 2, 3, 4
NSENSORS = 5
# int state I[...]
I_K, I_TOUCHING, I_NCONTACT, I_WARN0, I_JITTER = 0, 1, 2, 3, 4  # I_TOUCHING: size of the touching set
# float state F[...] (drive firmware state and the constants of a run)
(F_TV, F_TW, F_V, F_W, F_YAWI, F_REF, F_DT, F_DV, F_DW, F_SKID, F_KP, F_KI, F_HALFTRACK, F_RADIUS, F_HOLD,
 F_MU, F_FLOOR, F_EPS, F_MAXSPEED, F_SX, F_SY, F_MARGIN, F_COSFLIP, F_RATEJIT, F_UPZ) = (
    0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27)
NF = 28


def _void_mj(name: str) -> Any:
    """A numba intrinsic calling ``void name(const mjModel*, mjData*)`` with two addresses."""

    @intrinsic
    def call(typingctx: Any, m: Any, d: Any) -> Any:  # pragma: no cover - compile time
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            ptr = ir.IntType(8).as_pointer()
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr, ptr]), name)
            builder.call(fn, [builder.inttoptr(args[0], ptr), builder.inttoptr(args[1], ptr)])
            return context.get_dummy_value()

        return types.void(types.int64, types.int64), codegen

    return call


mj_fwdPosition = _void_mj("mj_fwdPosition")
mj_makeConstraint = _void_mj("mj_makeConstraint")
mj_projectConstraint = _void_mj("mj_projectConstraint")
mj_fwdVelocity = _void_mj("mj_fwdVelocity")
mj_step2 = _void_mj("mj_step2")


def _ptr(dtype: Any) -> Any:
    @intrinsic
    def cast(typingctx: Any, addr: Any) -> Any:  # pragma: no cover - compile time
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], context.get_value_type(types.CPointer(dtype)))

        return types.CPointer(dtype)(types.int64), codegen

    return cast


_f64ptr = _ptr(types.float64)
_i32ptr = _ptr(types.int32)
_i64ptr = _ptr(types.int64)


@numba.njit(cache=True)
def _read_ptr(addr: int) -> int:  # pragma: no cover - compiled
    return int(numba.carray(_i64ptr(addr), (1,))[0])


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
    hits = [h for h in np.flatnonzero(words[:-1] == d.qpos.ctypes.data) if words[h + 1] == d.qvel.ctypes.data]
    if len(hits) != 1:  # (the ``buffer`` field before it holds the same address)
        raise SimulationError(f"MuJoCo {mujoco.__version__}: cannot locate mjData.qpos ({len(hits)} candidates)")
    return int(base + 8 * (int(hits[0]) + gap))


@numba.njit(cache=True)
def _read_ncon(addr: int) -> int:  # pragma: no cover - compiled
    return int(numba.carray(_i32ptr(addr), (1,))[0])


@numba.njit(cache=True)
def _read_contacts(addr: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    cf = numba.carray(_f64ptr(addr), (n * _CF,))
    ci = numba.carray(_i32ptr(addr), (n * _CI,))
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
def _fire(k: int, I: np.ndarray, F: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, wqpos: np.ndarray,
          next_k: np.ndarray, period: np.ndarray, jit: np.ndarray, jit_idx: np.ndarray, samples: np.ndarray,
          nsamp: np.ndarray) -> int:  # pragma: no cover - compiled
    """Record the samples of the sensors due at step ``k``; LIDAR when the lidar is due (its
    schedule already advanced), FLUSH when a buffer is full (nothing recorded for that sensor)."""
    status = DONE
    t = k * F[F_DT]
    for s in range(NSENSORS):
        if next_k[s] > k:
            continue
        jittered = I[I_JITTER] != 0 and F[F_RATEJIT] > 0 and s != OBSERVER
        if (s != SCAN and nsamp[s] >= samples.shape[1]) or (jittered and jit_idx[s] >= jit.shape[1]):
            return status | FLUSH
        if s == SCAN:
            status |= LIDAR
        else:
            row = samples[s, nsamp[s]]
            row[0] = t
            if s == ODOM:
                for i in range(4):
                    row[1 + i] = qpos[wqpos[i]]
            else:
                yaw, pitch, roll = _euler(qpos)
                row[1], row[2], row[3] = yaw, pitch, roll
                if s == IMU:
                    row[4], row[5], row[6] = qvel[3], qvel[4], qvel[5]
                else:
                    row[4], row[5], row[6] = qpos[0], qpos[1], qpos[2]
            nsamp[s] += 1
        p = period[s]
        if jittered:
            p *= 1.0 + F[F_RATEJIT] * (2.0 * jit[s, jit_idx[s]] - 1.0)
            jit_idx[s] += 1
        next_k[s] = k + max(1, int(np.rint(p / F[F_DT])))
    return status


@numba.njit(cache=True)
def run_steps(maddr: int, daddr: int, ncon_addr: int, con_field: int, k_stop: int, I: np.ndarray, F: np.ndarray,
              qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray, xpos: np.ndarray, xmat: np.ndarray,
              warn: np.ndarray, bad_warn: np.ndarray, bodies: np.ndarray, wqpos: np.ndarray, wdof: np.ndarray,
              wheel_of_geom: np.ndarray, obstacle_of_geom: np.ndarray, contact_out: np.ndarray,
              contact_prev: np.ndarray,
              pool_every: int, pc: np.ndarray, ph: np.ndarray, pq: np.ndarray, preach: np.ndarray,
              pdist: np.ndarray, slot_obstacle: np.ndarray, slot_geom: np.ndarray, slot_mocap: np.ndarray,
              slot_bvh: np.ndarray, mocap_pos: np.ndarray, mocap_quat: np.ndarray, geom_size: np.ndarray,
              geom_rbound: np.ndarray, geom_aabb: np.ndarray, bvh_aabb: np.ndarray, geom_contype: np.ndarray,
              contype: int, park_z: float, next_k: np.ndarray, period: np.ndarray, jit: np.ndarray,
              jit_idx: np.ndarray, samples: np.ndarray, nsamp: np.ndarray) -> int:  # pragma: no cover
    """Fire the sensors due at the current step, then step until ``k_stop`` (or an event).

    ``bodies`` = (chassis, bumper geom, wheel bodies x4). Returns the status bits; the step count
    is ``I[I_K]``. CONTACT: the set of obstacles touched by the bumper changed; it is now
    ``contact_out[:I[I_NCONTACT]]`` (distinct indices; ``I[I_TOUCHING]`` its size, ``contact_prev``
    a copy). The up-vector z is in ``F[F_UPZ]``.
    """
    chassis, bumper = bodies[0], bodies[1]
    wbody = bodies[2:6]
    while True:
        k = I[I_K]
        st = _fire(k, I, F, qpos, qvel, wqpos, next_k, period, jit, jit_idx, samples, nsamp)
        if st != DONE or k >= k_stop:
            return st
        # ---- one physics step
        _drive(F, qpos, qvel, ctrl, wqpos)
        if pool_every > 0 and k % pool_every == 0:
            fill_obstacle_slots(qpos[0], qpos[1], pc, ph, pq, preach, pdist, slot_obstacle, slot_geom, slot_mocap,
                                slot_bvh, obstacle_of_geom, mocap_pos, mocap_quat, geom_size, geom_rbound,
                                geom_aabb, bvh_aabb, geom_contype, park_z, contype)
        mj_fwdPosition(maddr, daddr)
        n = _read_ncon(ncon_addr)
        con_addr = _read_ptr(con_field)
        cf = numba.carray(_f64ptr(con_addr), (n * _CF,))
        ci = numba.carray(_i32ptr(con_addr), (n * _CI,))
        if n > 0 and _align_wheel_contacts(cf, ci, n, wheel_of_geom, qvel, xmat[chassis], xpos[chassis], xpos,
                                           wbody, wdof, F[F_MU], F[F_FLOOR], F[F_EPS]) > 0:
            mj_makeConstraint(maddr, daddr)
            mj_projectConstraint(maddr, daddr)
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
        ci = numba.carray(_i32ptr(con_addr), (n * _CI,))
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
        changed = nk != I[I_TOUCHING]
        for i in range(nk):
            if changed:
                break
            found = False
            for j in range(nk):
                found = found or contact_prev[j] == contact_out[i]
            changed = not found
        if changed:  # Python sees only changes of the touching set (see Observer.hold)
            for i in range(nk):
                contact_prev[i] = contact_out[i]
            I[I_TOUCHING] = nk
            status |= CONTACT
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
