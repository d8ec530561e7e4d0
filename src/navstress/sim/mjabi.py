"""MuJoCo's C ABI, as the compiled step loop uses it: the one module that knows it.

A MuJoCo upgrade touches this file and ``tests/unit/sim/test_mjabi.py`` only. What it knows:

* **the library**: ``libmujoco`` beside the ``mujoco`` package, loaded into LLVM so that numba
  code calls its functions by symbol (:func:`_void_mj` intrinsics: the calls compile to direct
  calls, and the code caches with ``cache=True``);
* **the addresses**: of the ``mjModel``/``mjData`` behind the Python objects
  (:func:`model_address`, :func:`data_address`), of ``mjData.ncon`` (the int right after the
  ``timer`` array, :func:`ncon_address`) and of the pointer field ``mjData.contact``
  (:func:`contact_field_address`: found by the value of ``qpos`` followed, at their field
  offsets per ``mujoco.introspect``, by the addresses of other exposed arrays);
* **the mjContact layout**: the record size and the byte offsets of the fields read or written
  (``CON_*``; as rows of float64 / int32 in :func:`contacts`);
* **the stage order of** ``mj_fwdPosition`` (:func:`fwd_position_collision`,
  :func:`fwd_position_constraints`: the contacts can be changed between collision and
  constraints; the composition is bit-identical to ``mj_step``, tested);
* **the checks**: :func:`check_layout` compares every offset and the raw reads with the Python
  bindings once per process and raises :class:`~navstress.errors.SimulationError` on a mismatch
  instead of reading garbage.

Written for MuJoCo 4.0.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
from typing import Any, NamedTuple

import llvmlite.binding as llvm
import llvmlite.ir as ir
import mujoco
import numba
import numpy as np
from mujoco.introspect import ast_nodes, structs
from numba import carray, types  # type: ignore[attr-defined]
from numba.core import cgutils
from numba.extending import intrinsic

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.errors import SimulationError

LIBS = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
if LIBS:  # the symbols the intrinsics call; loading twice is harmless
    llvm.load_library_permanently(LIBS[0])

# ---- mjContact (bytes) ------------------------------------------------------------------------
CON_SIZE = 608
CON_DIST, CON_POS, CON_FRAME, CON_FRICTION = 0, 8, 32, 112  # double, double[3], double[9], double[5]
CON_GEOM1, CON_GEOM2, CON_GEOM, CON_EXCLUDE, CON_EFC = 556, 560, 564, 596, 600  # int, int, int[2], int, int
# the same in units of a contact row as float64 (CF_*) / int32 (CI_*), see ``contacts``
CF, CI = CON_SIZE // 8, CON_SIZE // 4
CF_DIST, CF_POS, CF_FRAME, CF_FRICTION = CON_DIST // 8, CON_POS // 8, CON_FRAME // 8, CON_FRICTION // 8
CI_GEOM1, CI_GEOM2, CI_GEOM, CI_EXCLUDE, CI_EFC = (CON_GEOM1 // 4, CON_GEOM2 // 4, CON_GEOM // 4, CON_EXCLUDE // 4,
                                                    CON_EFC // 4)
# field name in the bindings (``MjData.contact``) -> byte offset: what check_layout compares
CONTACT_OFFSETS = {"dist": CON_DIST, "pos": CON_POS, "frame": CON_FRAME, "friction": CON_FRICTION, "geom1": CON_GEOM1,
                   "geom2": CON_GEOM2, "geom": CON_GEOM, "exclude": CON_EXCLUDE, "efc_address": CON_EFC}
# exposed mjData arrays whose addresses must follow the qpos field at their offsets
_QPOS_NEIGHBOURS = ("qvel", "qacc_warmstart", "ctrl", "qfrc_applied", "xfrc_applied", "mocap_pos")


# ---- addresses (Python) -----------------------------------------------------------------------
def model_address(m: mujoco.MjModel) -> int:
    """Address of the ``mjModel`` behind ``m``."""
    return int(m._address)


def data_address(d: mujoco.MjData) -> int:
    """Address of the ``mjData`` behind ``d``."""
    return int(d._address)


def ncon_address(d: mujoco.MjData) -> int:
    """Address of ``d->ncon`` (the int right after the ``timer`` array)."""
    td = d.timer.duration
    return int(td.ctypes.data + td.shape[0] * td.strides[0])


def _words_upper_bound(fields: list[Any]) -> int:
    """At most how many 8-byte words ``fields`` (consecutive mjData fields of scalars, pointers
    and arrays of scalars) span."""
    words = 0
    for f in fields:
        t = f.type
        if isinstance(t, ast_nodes.ArrayType) and isinstance(t.inner_type, ast_nodes.ValueType) \
                and t.inner_type.name in _SCALARS:
            words += int(np.prod(t.extents))
        elif isinstance(t, ast_nodes.PointerType) or (isinstance(t, ast_nodes.ValueType) and t.name in _SCALARS):
            words += 1
        else:
            raise SimulationError(f"MuJoCo {mujoco.__version__}: mjData.{f.name} ({t}) between ncon and qpos "
                                  "has a size navstress.sim.mjabi cannot bound")
    return words


# scalar types of at most 8 bytes
_SCALARS = {"int", "mjtBool", "mjtByte", "mjtNum", "mjtSize", "float", "double", "size_t", "uintptr_t", "uint64_t",
            "char", "unsigned char"}
_FIELDS = structs.STRUCTS["mjData"].fields
_NAMES = [f.name for f in _FIELDS]
_QPOS = _NAMES.index("qpos")
_CONTACT_GAP = _NAMES.index("contact") - _QPOS  # pointer fields from qpos to contact


@functools.cache
def _qpos_max_word() -> int:
    """At most how many words after ``ncon`` the ``qpos`` field lies: the scan window ends inside
    mjData (reading past its end met stale copies of its pointers in the heap: a second candidate)."""
    return _words_upper_bound(_FIELDS[_NAMES.index("ncon"):_QPOS])


def find_qpos_field(words: np.ndarray, qpos: int, neighbours: list[tuple[int, int]], last: int) -> int:
    """Index in ``words`` (mjData's memory from ``ncon`` on, as uint64) of the ``qpos`` field: the
    one word at index <= ``last`` that holds ``qpos`` and, ``off`` words further for each
    (``off``, ``address``) of ``neighbours``, that address. SimulationError unless exactly one."""
    hits = [int(h) for h in np.flatnonzero(words[:last + 1] == qpos)
            if all(h + off < len(words) and words[h + off] == adr for off, adr in neighbours)]
    if len(hits) != 1:
        raise SimulationError(f"MuJoCo {mujoco.__version__}: cannot locate mjData.qpos ({len(hits)} candidates)")
    return hits[0]


def contact_field_address(d: mujoco.MjData) -> int:
    """Address of the pointer field ``d->contact``: found by locating the ``qpos`` field (its value,
    followed at their field offsets by the addresses of other arrays ``mjData`` exposes: the
    ``buffer`` field before it holds the same address as qpos), within mjData (the fields from
    ``ncon`` to ``qpos`` bound where it can be), then ``contact``'s distance from it per
    ``mujoco.introspect``."""
    checks = [(_NAMES.index(f) - _QPOS, getattr(d, f).ctypes.data) for f in _QPOS_NEIGHBOURS
              if f in _NAMES and getattr(d, f).size > 0]
    last = _qpos_max_word()
    n = last + max([_CONTACT_GAP] + [off for off, _ in checks]) + 1
    base = ncon_address(d)
    words = np.ctypeslib.as_array((ctypes.c_uint64 * n).from_address(base))
    return int(base + 8 * (find_qpos_field(words, d.qpos.ctypes.data, checks, last) + _CONTACT_GAP))


class Addresses(NamedTuple):
    """What the compiled loop needs to reach a model and its data."""

    model: int
    data: int
    ncon: int  # &d->ncon
    contact_field: int  # &d->contact (the pointer: MuJoCo may move the array)


def addresses(m: mujoco.MjModel, d: mujoco.MjData) -> Addresses:
    """The :class:`Addresses` of ``m`` and ``d``."""
    return Addresses(model_address(m), data_address(d), ncon_address(d), contact_field_address(d))


# ---- intrinsics ---------------------------------------------------------------------------
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


# ---- compiled reads and the stages of mj_fwdPosition ---------------------------------------
@numba.njit(cache=True)
def read_ptr(addr: int) -> int:  # pragma: no cover - compiled
    """The pointer (as an int) stored at ``addr``."""
    return int(carray(_i64ptr(addr), (1,))[0])


@numba.njit(cache=True)
def read_ncon(addr: int) -> int:  # pragma: no cover - compiled
    """The int at ``addr`` (``d->ncon`` at :func:`ncon_address`)."""
    return int(carray(_i32ptr(addr), (1,))[0])


@numba.njit(cache=True)
def contacts(ncon_addr: int, contact_field: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    """MuJoCo's current contacts in place, as rows of float64 (``cf[i, CF_FRAME + a]``) and of
    int32 (``ci[i, CI_GEOM]``): shapes (ncon, CF) and (ncon, CI), over the same memory."""
    n = read_ncon(ncon_addr)
    addr = read_ptr(contact_field)
    return carray(_f64ptr(addr), (n, CF)), carray(_i32ptr(addr), (n, CI))


@numba.njit(cache=True)
def read_contacts(addr: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    """Copies of (pos, frame, friction, geom) of the ``n`` contacts at ``addr``."""
    cf = carray(_f64ptr(addr), (n, CF))
    ci = carray(_i32ptr(addr), (n, CI))
    pos, frame, fr, geom = np.zeros((n, 3)), np.zeros((n, 9)), np.zeros((n, 5)), np.zeros((n, 2), np.int64)
    for i in range(n):
        for a in range(3):
            pos[i, a] = cf[i, CF_POS + a]
        for a in range(9):
            frame[i, a] = cf[i, CF_FRAME + a]
        for a in range(5):
            fr[i, a] = cf[i, CF_FRICTION + a]
        for a in range(2):
            geom[i, a] = ci[i, CI_GEOM + a]
    return pos, frame, fr, geom


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
    """Rest of ``mj_fwdPosition`` (without constraint islands: the model must disable them)."""
    mj_makeConstraint(maddr, daddr)
    mj_transmission(maddr, daddr)
    mj_projectConstraint(maddr, daddr)


@numba.njit(cache=True)
def add_contact(maddr: int, daddr: int, con: np.ndarray) -> bool:  # pragma: no cover - compiled
    """``mj_addContact`` of the contact whose raw bytes are ``con`` (``CF`` float64); False when
    MuJoCo's contact buffer is full."""
    return bool(mj_addContact(maddr, daddr, con.ctypes.data) == 0)


# ---- Python helpers ---------------------------------------------------------------------------
def contact_row(d: mujoco.MjData, i: int) -> np.ndarray:
    """A copy of the raw bytes of contact ``i`` of ``d``, as ``CF`` float64."""
    base = read_ptr(contact_field_address(d)) + i * CON_SIZE
    return np.ctypeslib.as_array((ctypes.c_double * CF).from_address(base)).copy()


_LAYOUT_OK: list[bool] = []


def check_layout() -> None:
    """Check, once per process, the library, every ``CON_*`` offset and the raw ``ncon`` /
    ``contact`` reads against the Python bindings on a small model; SimulationError otherwise."""
    if _LAYOUT_OK:
        return
    if not LIBS:
        raise SimulationError(f"libmujoco not found beside {mujoco.__file__}")
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="5 5 1"/><body pos="0.1 0.2 0.09" euler="0 0 0.3">'
        '<freejoint/><geom type="box" size=".1 .2 .1"/></body></worldbody></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    c = d.contact
    ok = d.ncon == 4 and read_ncon(ncon_address(d)) == d.ncon and c.dist.strides[0] == CON_SIZE
    base = c.dist.ctypes.data
    ok = ok and all(getattr(c, f).ctypes.data - base == off for f, off in CONTACT_OFFSETS.items())
    if ok:
        ok = read_ptr(contact_field_address(d)) == base
        pos, frame, fr, geom = read_contacts(read_ptr(contact_field_address(d)), d.ncon)
        ok = ok and (np.array_equal(pos, c.pos) and np.array_equal(frame, c.frame) and np.array_equal(fr, c.friction)
                     and np.array_equal(geom, c.geom))
    if not ok:
        raise SimulationError(f"MuJoCo {mujoco.__version__}: unexpected mjData/mjContact memory layout "
                              "(navstress.sim.mjabi assumes MuJoCo 4.0's)")
    _LAYOUT_OK.append(True)
