"""The named records of the sim kernels: every field given, none unknown, groups flattened in order."""

from __future__ import annotations

import inspect
from types import ModuleType

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from navstress.sim import _raybox, _raycast, _step, model, movers, native
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene

MODULES: tuple[ModuleType, ...] = (_raycast, _raybox, _step, model, movers)


def _records() -> list[type]:
    """Every NamedTuple class that a kernel module of navstress.sim defines."""
    found = []
    for mod in MODULES:
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ == mod.__name__ and issubclass(cls, tuple) and hasattr(cls, "_fields"):
                found.append(cls)
    return found


RECORDS = _records()


def test_the_kernel_modules_define_their_records() -> None:
    names = {c.__name__ for c in RECORDS}
    assert {"Ray", "Box", "Cell", "CellWalk", "TerrainGrid", "Beams", "NativeWalkArgs", "Cylinder", "LoopArrays",
            "Sphere", "HFieldGrid", "MjSlotArrays", "StaticBins", "MjArrays", "PoolArrays"} <= names


@pytest.mark.parametrize("cls", RECORDS, ids=lambda c: c.__name__)
def test_a_record_refuses_a_missing_or_unknown_field(cls: type) -> None:
    """No field has a default (a field added to a record must be given by every caller) and no
    unknown field is taken."""
    fields = cls._fields  # type: ignore[attr-defined]
    assert cls._field_defaults == {}  # type: ignore[attr-defined]
    full = {f: 0 for f in fields}
    assert tuple(cls(**full)) == (0,) * len(fields)
    for name in fields:
        with pytest.raises(TypeError, match=name):
            cls(**{f: v for f, v in full.items() if f != name})
    with pytest.raises(TypeError, match="not_a_field"):
        cls(**full, not_a_field=1)


def test_scan_params_need_every_field() -> None:
    """A scan's constants are named: new_scan_params refuses a missing or unknown field."""
    full = {"max_range": 70.0, "min_range": 0.3, "plane_march": 1, "walk": 0}
    assert set(full) == set(_raycast.SCAN_PARAMS.names or ())
    p = _raycast.new_scan_params(**full)
    assert p.dtype == _raycast.SCAN_PARAMS and p.shape == (1,) and p[0]["max_range"] == 70.0
    for name in full:
        with pytest.raises(TypeError, match=name):
            _raycast.new_scan_params(**{n: v for n, v in full.items() if n != name})
    with pytest.raises(TypeError, match="not_a_field"):
        _raycast.new_scan_params(**full, not_a_field=1)


def _lidar(**kw: bool) -> Lidar:
    h = np.zeros((6, 7), np.float32)
    return Lidar(LidarScene(h, 0.5, np.zeros((0, 7))), LidarConfig(channels=4, azimuth_steps=12, max_range_m=9.0,
                                                                   min_range_m=0.25), **kw)


def test_a_lidar_keeps_its_scan_constants_in_the_record() -> None:
    """The record the kernels read says what the Lidar was given, and follows plane_march and simd."""
    lid = _lidar(plane_march=False, simd=False)
    p = lid._params[0]
    assert (p["max_range"], p["min_range"], p["plane_march"], p["walk"]) == (9.0, 0.25, 0, 0)
    lid.plane_march = True
    assert lid.plane_march and lid._params[0]["plane_march"] == 1
    nat = native.load()
    if nat.address:  # (the native walk on: its address is the record's walk)
        lid.simd = True
        assert lid.simd and lid._params[0]["walk"] == nat.address
    lid.simd = False
    assert not lid.simd and lid._params[0]["walk"] == 0


def test_scan_arrays_flatten_the_groups_in_order() -> None:
    """scan_ranges and body_scan_ranges regroup their flat arguments by the groups' field counts:
    scan_arrays gives a TerrainGrid's fields, a Beams' fields, then the ranges, and refuses groups
    out of order."""
    lid = _lidar()
    grid, beams = lid.scene.grid, lid._beams
    flat = _raybox.scan_arrays(grid, beams, lid._out)
    assert len(flat) == len(_raycast.TerrainGrid._fields) + len(_raycast.Beams._fields) + 1
    assert all(a is b for a, b in zip(flat, (*grid, *beams, lid._out)))
    assert flat[0] is lid.scene.heights and flat[1] == lid.scene.cell_m and flat[-1] is lid._out
    with pytest.raises(TypeError, match="expected TerrainGrid and Beams"):
        _raybox.scan_arrays(beams, grid, lid._out)  # type: ignore[arg-type]


def test_the_flat_entry_equals_the_kernels_on_records() -> None:
    """Lidar._ranges (one flat call) gives the same bits as terrain_kernel then box_pass called on
    the records."""
    h = (np.random.default_rng(4).uniform(0, 1, (9, 11)).cumsum(0) / 5).astype(np.float32)
    sc = LidarScene(h, 0.7, np.array([[3.0, 2.0, 0.4, 0.5, 0.3, -1.0, 3.0]]))
    lid = Lidar(sc, LidarConfig(channels=6, azimuth_steps=40, max_range_m=12.0), simd=False)
    origin, rot = np.array([3.5, 2.9, 2.5]), np.eye(3)
    got = lid._ranges(origin, rot).copy()
    ref = np.empty_like(got)
    _raycast.terrain_kernel(sc.grid, lid._beams, lid._params, origin, rot, ref)
    _raybox.box_pass(sc.boxes, lid._beams, lid._params, origin, rot, ref)
    assert np.isfinite(got).any() and got.tobytes() == ref.tobytes()


def test_the_native_call_refuses_arguments_of_the_wrong_kind() -> None:
    """nv_march_channel's arguments are typed where the call is compiled: a float where an address
    or a count belongs (or a plain tuple) is a typing error, never a call with garbage."""
    good = (1, 2, 3, 4, 0.5, 0.5, 0.5, 0, 5, 6, 7, 8)

    @njit
    def call(fn: int, args: _raycast.NativeWalkArgs) -> None:
        if fn != 0:  # (typed when compiled; never called here)
            _raycast._call_native_walk(fn, args)

    for bad in (_raycast.NativeWalkArgs(*good[:4], 1, *good[5:]),  # an integer z
                _raycast.NativeWalkArgs(1.0, *good[1:]),  # a float address
                good):  # not a NativeWalkArgs
        with pytest.raises(TypingError):
            call(0, bad)
