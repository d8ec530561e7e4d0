"""benchmarks/identity_robots.py BEFORE AFTER: the outputs of ``benchmarks/identity.sh`` made
before robots were recorded (BEFORE) and after (AFTER) are the same work, apart from exactly what
recording the robot adds:

- every line of the two digests is equal, except the store's ``runs`` tables, ``analyze.json``,
  ``gate.json`` and the MCAP traces;
- the ``runs`` tables' rows, without the wall-clock columns and the new ``robot`` and
  ``robot_digest`` columns, are equal, and every run's robot is ``rmp400`` with its digest;
- ``analyze.json`` and ``gate.json`` are equal once their new ``robots`` keys are removed;
- in every trace, every message but ``/robot/body`` is equal (topic, log time, publish time,
  sequence, bytes), the ``navstress.run`` metadata is equal and ``navstress.robot`` (rmp400) is
  the one metadata record added; ``/robot/body``'s entities are equal once the added footprint
  outline (their ``lines``) is removed.

Prints one line per check and exits 1 when one fails.

    python benchmarks/identity_robots.py /tmp/id-base /tmp/id-new
"""

from __future__ import annotations

import json
import sqlite3
import sys
from pathlib import Path
from typing import Any

from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader

from navstress.robot import RobotSpec

WALL = ("recorded_at", "at", "wall_s", "started_at", "finished_at", "elapsed_s")
ROBOT = ("robot", "robot_digest")
EXPECTED = ("runs ", "analyze.json", "gate.json", ".mcap")


def _digest_lines(root: Path) -> dict[str, str]:
    out = {}
    for line in (root / "digest.txt").read_text().splitlines():
        key, _, h = line.rpartition(" ")
        out[key] = h
    return out


def _rows(db: Path, drop: tuple[str, ...]) -> tuple[list[Any], list[Any]]:
    con = sqlite3.connect(db)
    cols = [c[1] for c in con.execute("pragma table_info(runs)")]
    keep = [c for c in cols if c not in WALL + drop]
    rows = con.execute(f"select {','.join(keep)} from runs order by 1").fetchall()
    robots = con.execute("select robot, robot_digest from runs").fetchall() if "robot" in cols else []
    con.close()
    return rows, robots


def _strip(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k != "robots"}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _trace(p: Path) -> tuple[list[Any], dict[str, dict[str, str]]]:
    with open(p, "rb") as f:
        msgs = [(ch.topic, m.log_time, m.publish_time, m.sequence, m.data)
                for _s, ch, m in make_reader(f).iter_messages(log_time_order=False)]
    with open(p, "rb") as f:
        md = {x.name: dict(x.metadata) for x in make_reader(f).iter_metadata()}
    return msgs, md


def _bodies_equal(a: list[Any], b: list[Any]) -> bool:
    if len(a) != len(b):
        return False
    for ma, mb in zip(a, b):
        if ma[:4] != mb[:4]:
            return False
        ua, ub = SceneUpdate.FromString(ma[4]), SceneUpdate.FromString(mb[4])
        if len(ua.entities) != len(ub.entities):
            return False
        for ea, eb in zip(ua.entities, ub.entities):
            eb2 = type(eb)()
            eb2.CopyFrom(eb)
            del eb2.lines[:]
            if ea.SerializeToString() != eb2.SerializeToString():
                return False
    return True


def main(before: Path, after: Path) -> int:
    ok = True
    da, db = _digest_lines(before), _digest_lines(after)
    other = [k for k in sorted(set(da) | set(db)) if not any(e in k for e in EXPECTED) and da.get(k) != db.get(k)]
    print(f"digest lines other than runs/analyze/gate/traces equal: {not other} ({len(da)} lines)", *other[:5])
    ok &= not other
    rmp = RobotSpec()
    for sq in sorted(before.rglob("*.sqlite")):
        ra, _ = _rows(sq, ())
        rb, robots = _rows(after / sq.relative_to(before), ROBOT)
        same = ra == rb and set(robots) == {(rmp.name, rmp.digest)}
        print(f"{sq.relative_to(before)} runs: {len(ra)} rows equal without the robot columns, all rmp400: {same}")
        ok &= same
    for name in ("analyze.json", "gate.json"):
        same = _strip(json.loads((before / name).read_text())) == _strip(json.loads((after / name).read_text()))
        print(f"{name} equal without its robots keys: {same}")
        ok &= same
    n = good = 0
    for a in sorted(before.rglob("*.mcap")):
        ma, mda = _trace(a)
        mb, mdb = _trace(after / a.relative_to(before))
        n += 1
        same = ([m for m in ma if m[0] != "/robot/body"] == [m for m in mb if m[0] != "/robot/body"]
                and mda.get("navstress.run") == mdb.get("navstress.run") and set(mdb) - set(mda) == {"navstress.robot"}
                and mdb["navstress.robot"].get("name") == "rmp400"
                and _bodies_equal([m for m in ma if m[0] == "/robot/body"], [m for m in mb if m[0] == "/robot/body"]))
        good += same
        if not same:
            print("trace differs:", a.relative_to(before))
    print(f"{good}/{n} traces equal but for the robot's metadata and footprint outline")
    ok &= good == n and n > 0
    return 0 if ok else 1


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
