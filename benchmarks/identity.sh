#!/usr/bin/env bash
# benchmarks/identity.sh TREE OUT: the same work (the demo campaign, a 60-run failure search, its
# suite run again with `campaign run`, `gate --junit`, `analyze --json`) run with TREE's code, and a
# digest of what it wrote (OUT/digest.txt): every store table's rows without the wall-clock
# columns, every other file's bytes (gate.xml without its times and timestamps). Run it at two
# revisions (e.g. two `git worktree`s) and diff the digests: a redesign that keeps behaviour
# prints nothing. About 3 minutes on 2 cores.
#   benchmarks/identity.sh /tmp/before /tmp/id-before; benchmarks/identity.sh . /tmp/id-after
#   diff /tmp/id-before/digest.txt /tmp/id-after/digest.txt
set -eu
[ $# -eq 2 ] || { echo "usage: $0 TREE OUT" >&2; exit 2; }
tree=$(cd "$1" && pwd); out=$2; rm -rf "$out"; mkdir -p "$out"
py=${PYTHON:-$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/python}
export PYTHONPATH=$tree/src
ns() { "$py" -m navstress.cli "$@"; }
cd "$out"
ns demo -o demo -j 2 >/dev/null 2>&1
ns search init -o s.yaml >/dev/null
"$py" - <<'PY'
import yaml
d = yaml.safe_load(open("s.yaml"))
d.setdefault("budget", {})["runs"] = 60
yaml.safe_dump(d, open("s.yaml", "w"))
PY
ns search run s.yaml -o search -j 2 -q >/dev/null 2>&1 || echo "search rc=$?"
ns campaign run search/suite/*.yaml -o suiterun -j 2 -q >/dev/null 2>&1 || ls search/suite
ns gate demo/campaign --min-success 0.1 --junit gate.xml --json > gate.json || true
ns analyze demo/campaign --json - > analyze.json
"$py" - <<'PY' > digest.txt
import hashlib, pathlib, re, sqlite3
root = pathlib.Path(".")
WALL = ("recorded_at", "at", "wall_s", "started_at", "finished_at", "elapsed_s")
def h(b): return hashlib.sha256(b).hexdigest()[:16]
for db in sorted(root.rglob("*.sqlite")):
    con = sqlite3.connect(db)
    for (t,) in con.execute("select name from sqlite_master where type='table' order by name"):
        keep = [c[1] for c in con.execute(f"pragma table_info({t})") if c[1] not in WALL]
        rows = con.execute(f"select {','.join(keep)} from {t} order by 1").fetchall()
        print(db, t, len(rows), h(repr(rows).encode()))
for f in sorted(p for p in root.rglob("*") if p.is_file()):
    if f.name == "digest.txt" or f.suffix in (".sqlite", ".html", ".log") or "sqlite" in f.name:
        continue
    b = f.read_bytes()
    if f.name == "gate.xml":  # wall-clock times and timestamps are the only run-to-run differences
        b = re.sub(rb'(time|timestamp)="[^"]*"|wall [0-9.]+ s', b"", b)
    print(f, h(b))
PY
echo "digest: $out/digest.txt ($(wc -l < digest.txt) lines)"
