"""MuJoCo's C ABI as navstress.sim.mjabi knows it: the mj_fwdPosition stage composition, the
mjContact offsets, the ncon / contact addresses and the raw reads, checked against the bindings."""

from __future__ import annotations

import math
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

import navstress
from navstress.errors import SimulationError
from navstress.sim import SimConfig, Simulation
from navstress.sim import mjabi
from navstress.sim.model import build_model

from tests.support.sim_worlds import bumpy

NOLIDAR = SimConfig(lidar_enabled=False)


def test_composed_fwd_position_is_bit_identical_to_mj_step() -> None:
    rm = build_model(bumpy(), start=(10.0, 10.0, 0.5))
    m = rm.model
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
    da, db = mujoco.MjData(m), mujoco.MjData(m)
    ncon = []
    for k in range(300):
        u = [0.5 * math.sin(k / 40), 0.4, -0.3, -0.3 * math.cos(k / 25)]
        da.ctrl[:] = u
        db.ctrl[:] = u
        mujoco.mj_step(m, da)
        mjabi.fwd_position_collision(mjabi.model_address(m), mjabi.data_address(db))
        mjabi.fwd_position_constraints(mjabi.model_address(m), mjabi.data_address(db))
        mujoco.mj_fwdVelocity(m, db)
        mujoco.mj_step2(m, db)
        ncon.append(db.ncon)
    assert max(ncon) >= 3  # the wheels were on the ground
    assert np.array_equal(da.qpos, db.qpos) and np.array_equal(da.qvel, db.qvel)


def test_raw_contact_reads_match_the_bindings() -> None:
    mjabi.check_layout()
    sim = Simulation(bumpy(), config=NOLIDAR, seed=0, start=(10.0, 10.0, 0.5))
    sim.advance(1.0)
    d = sim.data
    assert d.ncon >= 3
    assert mjabi.read_ncon(mjabi.ncon_address(d)) == d.ncon
    pos, frame, fr, geom = mjabi.read_contacts(mjabi.read_ptr(mjabi.contact_field_address(d)), d.ncon)
    c = d.contact
    assert np.array_equal(pos, c.pos) and np.array_equal(frame, c.frame)
    assert np.array_equal(fr, c.friction) and np.array_equal(geom, c.geom)


def test_contact_field_is_found_in_every_new_mjdata() -> None:
    """The pointer scan finds exactly one mjData.qpos in every MjData (a paper-slice run once
    met two candidates when only qpos and qvel were matched): the same field offset each time,
    holding the contacts the bindings show."""
    sim = Simulation(bumpy(), config=NOLIDAR, seed=0, start=(10.0, 10.0, 0.5))
    offsets = set()
    for _ in range(200):
        d = mujoco.MjData(sim.model)
        offsets.add(mjabi.contact_field_address(d) - mjabi.ncon_address(d))
    assert len(offsets) == 1
    sim.advance(1.0)
    d = sim.data
    assert mjabi.contact_field_address(d) - mjabi.ncon_address(d) in offsets
    pos, _frame, _fr, _geom = mjabi.read_contacts(mjabi.read_ptr(mjabi.contact_field_address(d)), d.ncon)
    assert d.ncon >= 3 and np.array_equal(pos, d.contact.pos)


def _contacts_sim() -> Simulation:
    sim = Simulation(bumpy(), config=NOLIDAR, seed=0, start=(10.0, 10.0, 0.5))
    sim.advance(1.0)
    assert sim.data.ncon >= 3
    return sim


@pytest.mark.parametrize("field", sorted(mjabi.CONTACT_OFFSETS))
def test_every_contact_offset_is_where_the_bindings_have_the_field(field: str) -> None:
    d = _contacts_sim().data
    c = d.contact
    assert c.dist.strides[0] == mjabi.CON_SIZE
    assert getattr(c, field).ctypes.data - c.dist.ctypes.data == mjabi.CONTACT_OFFSETS[field]


def test_contact_rows_in_place_and_copied_equal_the_bindings() -> None:
    """mjabi.contacts (the loop's in-place view) and contact_row (a copy) read every field the
    loop uses as the bindings show it."""
    d = _contacts_sim().data
    c = d.contact
    cf, ci = mjabi.contacts(mjabi.ncon_address(d), mjabi.contact_field_address(d))
    assert cf.shape == (d.ncon, mjabi.CF) and ci.shape == (d.ncon, mjabi.CI)
    for i in range(d.ncon):
        for row in (cf[i], mjabi.contact_row(d, i)):
            ri = row.view(np.int32)
            assert row[mjabi.CF_DIST] == c.dist[i]
            assert np.array_equal(row[mjabi.CF_POS:mjabi.CF_POS + 3], c.pos[i])
            assert np.array_equal(row[mjabi.CF_FRAME:mjabi.CF_FRAME + 9], c.frame[i])
            assert np.array_equal(row[mjabi.CF_FRICTION:mjabi.CF_FRICTION + 5], c.friction[i])
            assert (ri[mjabi.CI_GEOM1], ri[mjabi.CI_GEOM2]) == (c.geom1[i], c.geom2[i])
            assert np.array_equal(ri[mjabi.CI_GEOM:mjabi.CI_GEOM + 2], c.geom[i])
            assert (ri[mjabi.CI_EXCLUDE], ri[mjabi.CI_EFC]) == (c.exclude[i], c.efc_address[i])


@pytest.mark.parametrize("field,shift", [(f, s) for f in sorted(mjabi.CONTACT_OFFSETS) for s in (-4, 8)])
def test_check_layout_rejects_a_wrong_offset(field: str, shift: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """A MuJoCo whose mjContact moved a field (here: the offset navstress assumes is shifted) is
    refused with one SimulationError, not read."""
    monkeypatch.setattr(mjabi, "_LAYOUT_OK", [])
    monkeypatch.setitem(mjabi.CONTACT_OFFSETS, field, mjabi.CONTACT_OFFSETS[field] + shift)
    with pytest.raises(SimulationError, match="unexpected mjData/mjContact memory layout"):
        mjabi.check_layout()


def test_addresses_are_the_bindings_objects() -> None:
    d = _contacts_sim().data
    adr = mjabi.addresses(_contacts_sim().model, d)
    assert adr.ncon == mjabi.ncon_address(d) and adr.contact_field == mjabi.contact_field_address(d)
    assert mjabi.read_ptr(adr.contact_field) == d.contact.dist.ctypes.data
    assert mjabi.read_ncon(adr.ncon) == d.ncon


SRC = Path(navstress.__file__).parent
# what knowing MuJoCo's C ABI looks like in source: private addresses, the library, symbols by
# name, struct introspection, contact layout constants, the ncon-after-timer trick
ABI_PATTERNS = {
    "private address": r"\._address\b",
    "the library": r"libmujoco",
    "symbol by name": r"[\"']mj_[A-Za-z0-9]+[\"']",
    "struct layout": r"mujoco\.introspect|from mujoco import introspect",
    "contact offsets": r"\bCON_[A-Z0-9]+\s*[,=]",
    "ncon address": r"timer\.duration",
}


@pytest.mark.parametrize("what", sorted(ABI_PATTERNS))
def test_only_mjabi_knows_mujocos_abi(what: str) -> None:
    """A MuJoCo upgrade touches navstress.sim.mjabi only: no other source file matches (and
    mjabi.py does, so the pattern is not vacuous)."""
    pat = re.compile(ABI_PATTERNS[what])
    abi = SRC / "sim" / "mjabi.py"
    assert pat.search(abi.read_text())
    offenders = [str(p.relative_to(SRC)) for p in sorted(SRC.rglob("*.py")) if p != abi and pat.search(p.read_text())]
    assert offenders == []


QPOS, NEIGHBOURS = 0x7F0000001000, [(1, 0x7F0000002000), (5, 0x7F0000003000), (40, 0x7F0000004000)]


def _memory(seed: int, at: list[int]) -> np.ndarray:
    """Random words with the qpos pattern (value, then the neighbours' addresses) at ``at``, and
    the qpos value alone (as mjData.buffer holds it) before the first."""
    words = np.random.default_rng(seed).integers(1, 2**62, 1000, dtype=np.int64).astype(np.uint64)
    cells = [{x, *(x + off for off, _ in NEIGHBOURS)} for x in at]
    assume(all(not (c & e) for i, c in enumerate(cells) for e in cells[i + 1:]))
    for x in at:
        words[x] = QPOS
        for off, adr in NEIGHBOURS:
            words[x + off] = adr
    if min(at) > 0:
        words[min(at) - 1] = QPOS
    return words


@settings(max_examples=60, deadline=None)
@given(real=st.integers(0, 30), copies=st.lists(st.integers(31, 900), max_size=3), other=st.integers(0, 30),
       seed=st.integers(0, 2**31))
def test_qpos_scan_finds_the_field_and_ignores_copies_beyond_it(real: int, copies: list[int], other: int,
                                                                seed: int) -> None:
    """The qpos field is the one word within the window's first ``last`` words holding qpos and,
    at their offsets, the neighbouring arrays' addresses: copies of that pattern further on (stale
    heap memory past mjData's end once gave a second candidate) are not candidates; a second one
    within reach, or none, is an error."""
    assert mjabi.find_qpos_field(_memory(seed, [real, *copies]), QPOS, NEIGHBOURS, 30) == real
    with pytest.raises(SimulationError, match="0 candidates"):
        mjabi.find_qpos_field(_memory(seed, [real, *copies]), QPOS + 8, NEIGHBOURS, 30)
    assume(other != real)
    with pytest.raises(SimulationError, match="2 candidates"):
        mjabi.find_qpos_field(_memory(seed, [real, other, *copies]), QPOS, NEIGHBOURS, 30)


def test_qpos_window_lies_within_mjdata() -> None:
    """The scan reads from ncon up to contact (and the checked neighbours) of the real qpos field
    only: the window's first ``last`` words cover the real field, and the real field's offset
    leaves the contact pointer inside the window."""
    d = _contacts_sim().data
    last = mjabi._qpos_max_word()
    field = mjabi.contact_field_address(d)
    qpos_word = (field - mjabi.ncon_address(d)) // 8 - mjabi._CONTACT_GAP
    assert 0 <= qpos_word <= last
    assert mjabi.read_ptr(field) == d.contact.dist.ctypes.data
