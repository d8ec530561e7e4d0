"""Every file and directory a command writes follows the umask (never mkstemp's 0600 or
mkdtemp's 0700): a Gazebo container running as another user, or a Ray node with another uid,
must be able to read worlds, exports, traces, stores and reports.

Each umask gets one subprocess (its umask set by ``subprocess.run(umask=...)``) that runs every
command that writes files, in process, each into its own output folder; each command x umask
is then one test over what that command wrote.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.support.built_once import built_once

pytestmark = pytest.mark.slow

#: 002 and 077 bracket the common 022: a writer that ignores the umask (mkstemp's 0600, a fixed
#: 0644) is caught by one of them (0644 under 002 lacks group write; under 077 it opens too much),
#: while 022's expected 0644 would let a fixed 0644 pass.
UMASKS = (0o002, 0o077)

SPEC = {"name": "modes", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "e", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "maps_per_config": 1, "runs_per_map": 1, "navigators": [{"name": "reference-v1"}],
        "faults": [None], "timeout_s": 4.0, "goal_tolerance_m": 2.0}

# command name -> (argv with {R} for the root, the output path it writes under R)
COMMANDS: dict[str, tuple[list[str], str]] = {
    "world generate": (["world", "generate", "-o", "{R}/gen/w", "--size", "20", "--cell", "0.5", "--seed", "1"],
                       "gen"),
    "world show": (["world", "show", "{R}/gen/w", "-o", "{R}/show/p/preview.png"], "show"),
    **{f"world export {fmt}": (["world", "export", "{R}/gen/w", "-f", fmt, "-o", f"{{R}}/export-{fmt}/d/w.{fmt}"],
                                f"export-{fmt}")
       for fmt in ("mjcf", "sdf", "gltf", "glb", "obj", "png")},
    "world drive": (["world", "drive", "{R}/gen/w", "-o", "{R}/drive/d/drive.png", "--course", "0.5,0,1"], "drive"),
    "run": (["run", "{R}/gen/w", "-o", "{R}/run/out", "--runs", "1", "--timeout", "2"], "run"),
    "campaign init": (["campaign", "init", "-o", "{R}/init/d/spec.yaml", "--preset", "demo"], "init"),
    "campaign run": (["campaign", "run", "{R}/spec.yaml", "-o", "{R}/camp/c", "-j", "1", "-q"], "camp"),
    "campaign export csv": (["campaign", "export", "{R}/camp/c", "-f", "csv", "-o", "{R}/cexp-csv/d/r.csv"],
                            "cexp-csv"),
    "campaign export parquet": (["campaign", "export", "{R}/camp/c", "-f", "parquet", "-o",
                                 "{R}/cexp-parquet/d/r.parquet"], "cexp-parquet"),
    "report": (["report", "{R}/camp/c", "-o", "{R}/report/d/report.html"], "report"),
    "analyze": (["analyze", "{R}/camp/c", "--json", "{R}/analyze/d/a.json"], "analyze"),
    "replay": (["replay", "{R}/camp/c", "e/c0/m0/r0/reference-v1/nominal", "--keep", "{R}/replay/d/new.mcap"],
               "replay"),
}

DRIVER = r"""
import json, sys
from navstress.cli import app
root, cmds = sys.argv[1], json.loads(sys.argv[2])
codes = {}
for name, argv in cmds.items():
    try:
        app([a.replace("{R}", root) for a in argv], standalone_mode=False)
        codes[name] = 0
    except SystemExit as e:
        codes[name] = e.code if isinstance(e.code, int) else 1
    except BaseException as e:
        codes[name] = f"{type(e).__name__}: {e}"
print("CODES=" + json.dumps(codes))
"""


def _written(umask: int, root: Path) -> list[object]:
    """Every command run in one subprocess whose umask is ``umask``, each into its own folder of
    ``root``: [umask, root, each command's exit code]."""
    os.chmod(root, 0o755)
    (root / "spec.yaml").write_text(yaml.safe_dump(SPEC, sort_keys=False))
    run_id = _first_run_id(root)
    cmds = {name: [a.replace("e/c0/m0/r0/reference-v1/nominal", run_id) for a in argv]
            for name, (argv, _out) in COMMANDS.items()}
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    out = subprocess.run([sys.executable, "-c", DRIVER, str(root), json.dumps(cmds)], capture_output=True, text=True,
                         timeout=500, umask=umask, env=env)
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("CODES=")]
    assert line, out.stdout[-3000:] + out.stderr[-3000:]
    return [umask, str(root), json.loads(line[-1][len("CODES="):])]


@pytest.fixture(scope="module", params=UMASKS, ids=lambda u: f"umask{u:03o}")
def written(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Path, dict[str, object]]:
    """Built once per umask in the session (the tests only read what the commands wrote)."""
    umask: int = request.param
    got = built_once(tmp_path_factory, f"file-modes-umask{umask:03o}", lambda root: _written(umask, root))
    return got[0], Path(got[1]), got[2]


def _first_run_id(root: Path) -> str:
    from navstress.campaign.plan import plan
    from navstress.campaign.spec import load_campaign

    return plan(load_campaign(root / "spec.yaml")[0], root / "x").tasks[0].run_id


def _wrong_modes(top: Path, umask: int) -> list[str]:
    want_file, want_dir = 0o666 & ~umask, 0o777 & ~umask
    wrong = []
    for dirpath, dirnames, filenames in os.walk(top):
        for d in dirnames:
            m = stat.S_IMODE(os.lstat(os.path.join(dirpath, d)).st_mode)
            if m != want_dir:
                wrong.append(f"{os.path.join(dirpath, d)}/ is {m:04o}, want {want_dir:04o}")
        for f in filenames:
            m = stat.S_IMODE(os.lstat(os.path.join(dirpath, f)).st_mode)
            if m != want_file:
                wrong.append(f"{os.path.join(dirpath, f)} is {m:04o}, want {want_file:04o}")
    return wrong


@pytest.mark.parametrize("command", list(COMMANDS))
def test_outputs_follow_the_umask(written: tuple[int, Path, dict[str, object]], command: str) -> None:
    umask, root, codes = written
    assert codes[command] == 0, f"{command} failed: {codes[command]}"
    top = root / COMMANDS[command][1]
    assert top.is_dir() and any(p.is_file() for p in top.rglob("*")), f"{command} wrote nothing under {top}"
    assert _wrong_modes(top, umask) == []
