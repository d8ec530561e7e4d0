"""Rules of the code that no reader keeps by eye, checked on the syntax trees of src/navstress (as
tests/unit/test_layers.py checks the layers). Each rule is a function from a module's source to
what breaks it, run over every module, and run on a small made-up source that breaks it, so that
a check which found nothing cannot be a check that looks at nothing.

1. **Renames into place are written once**, in ``navstress._files`` (docs/design.md, invariants 4
   and 6: a unique temporary name beside the file, never through a link, nothing left behind):
   no ``os.replace``, ``os.rename``, ``os.renames``, ``shutil.move``, ``Path.replace`` or
   ``Path.rename`` anywhere else. A ``.replace(x)`` or ``.rename(x)`` call with exactly one
   positional argument and no keyword is a Path's (``str.replace`` takes two; ``dataclasses.replace``
   is told apart by its module).
2. **A private name stays in its package.** A *package* is a top-level subpackage
   (``navstress.world``, ``navstress.run``, ...: every module under it, nested packages included);
   each module at the root (``navstress._files``, ``navstress.errors``) is a package of its own,
   and so is the root's ``__init__``. A name with one leading underscore, and anything in a
   private module below a package (``navstress.sim._step``, ``navstress.world.export._grid``), is
   imported (``from M import _x``, ``import navstress.p._m``) or read off an imported module
   (``registry._registered``) only by modules of the package that defines it. The private modules
   at the root (``_files``, ``_json``, ``_jit``, ``_tables``, ``_models``, ...) are the project's
   shared internals: any module may import them (the underscore says "not for plug-in authors",
   the layer test says who may), but not the private names inside them. A name shared across
   packages is made public where it lives (or moved), never reached into.
3. **No function takes more than 8 positional parameters** (positional-only and ordinary ones;
   a method's ``self``/``cls`` is not counted, keyword-only ones are free): past that, a call
   passes values whose meaning is their position. Name them: keyword-only parameters, or a
   record (``sim/_step.py``'s ``STATE``/``PARAMS``).
4. **A function-level import of navstress's own says why**, on its line or in the comment just
   above it (the import cost of a command, a cycle, a worker that must stay light):
   docs/design.md, "No work at import"; everything else is imported at the top of its module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import navstress

PKG = Path(navstress.__file__).resolve().parent


def _module_names() -> dict[str, Path]:
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        parts = list(p.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


MODULES = _module_names()
PACKAGES = {m for m, p in MODULES.items() if p.name == "__init__.py"}


def _source(module: str) -> str:
    return MODULES[module].read_text(encoding="utf-8")


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _resolve(module: str, node: ast.ImportFrom, packages: set[str]) -> str:
    """The absolute module a ``from ... import`` names (relative imports resolved)."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if module in packages else module.split(".")[:-1]
    base = base[: len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


# ---- 1. renames into place ------------------------------------------------------------------

RENAME_HOME = "navstress._files"
_RENAMING = {"os": ("replace", "rename", "renames"), "shutil": ("move",)}


def hand_renames(module: str, source: str) -> list[str]:
    """Each place in ``source`` that renames a file itself (rule 1)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module in _RENAMING and \
                any(a.name in _RENAMING[node.module] for a in node.names):
            out.append(f"{module}:{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                node.attr in _RENAMING.get(node.value.id, ()):
            out.append(f"{module}:{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                node.func.attr in ("replace", "rename") and len(node.args) == 1 and not node.keywords and \
                not (isinstance(node.func.value, ast.Name) and node.func.value.id in ("os", "dataclasses")):
            out.append(f"{module}:{node.lineno}: {ast.unparse(node)}")
    return out


def test_renames_into_place_only_in_the_files_helpers() -> None:
    found = [f for m in MODULES if m != RENAME_HOME for f in hand_renames(m, _source(m))]
    assert found == [], "rename through navstress._files (write_atomic, replaced_on_success, " \
                        "rename_into_place, replace_dir):\n" + "\n".join(found)


def test_the_helpers_module_is_where_the_renames_are() -> None:
    assert len(hand_renames(RENAME_HOME, _source(RENAME_HOME))) >= 4


@pytest.mark.parametrize("code", [
    "import os\nos.replace(tmp, dest)",
    "import os\nos.rename(tmp, dest)",
    "import os\nos.renames(tmp, dest)",
    "import shutil\nshutil.move(tmp, dest)",
    "from os import replace",
    "from os import rename as mv",
    "tmp.replace(dest)",
    "Path(tmp).rename(dest)",
    "self._tmp.replace(self.path)",
    "def f(tmp, dest):\n    with open(tmp, 'w') as f:\n        f.write('x')\n    tmp.rename(dest)",
    "import os\nmove = os.replace",
])
def test_hand_renames_are_found(code: str) -> None:
    assert len(hand_renames("navstress.x", code)) == 1


@pytest.mark.parametrize("code", [
    "text.replace('a', 'b')",
    "text.replace('a', 'b', 1)",
    "import dataclasses\ndataclasses.replace(cfg, x=1)",
    "import dataclasses\ndataclasses.replace(cfg)",
    "when.replace(tzinfo=None)",
    "from navstress import _files\n_files.rename_into_place(tmp, dest)",
    "name.rename",
])
def test_what_is_not_a_rename_passes(code: str) -> None:
    assert hand_renames("navstress.x", code) == []


# ---- 2. private names stay in their package -------------------------------------------------


def package_of(module: str) -> str:
    """``navstress.world.export.sdf`` -> ``navstress.world``; a root module is its own package."""
    return ".".join(module.split(".")[:2])


def _private_module(module: str) -> bool:
    """A module private to its package: a private segment below the top-level subpackage (the
    root's private modules are shared)."""
    return any(_private(s) for s in module.split(".")[2:])


def private_crossings(module: str, source: str, modules: set[str], packages: set[str]) -> list[str]:
    """Each private name of another package that ``source`` (module ``module``) imports or reads
    off an imported module (rule 2)."""
    here = package_of(module)
    out: list[str] = []

    def check(target_module: str, name: str | None, line: int) -> None:
        """``name`` (None: the module itself) of ``target_module``, used at ``line``."""
        if package_of(target_module) == here:
            return
        if _private_module(target_module) or (name is not None and _private(name)):
            out.append(f"{module}:{line}: {target_module}{'' if name is None else '.' + name}")

    tree = ast.parse(source)
    bound: dict[str, str] = {}  # local name -> the navstress module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            mod = _resolve(module, node, packages)
            if not (mod == "navstress" or mod.startswith("navstress.")):
                continue
            for a in node.names:
                full = f"{mod}.{a.name}"
                if full in modules:
                    check(full, None, node.lineno)
                    bound[a.asname or a.name] = full
                else:
                    check(mod, a.name, node.lineno)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "navstress" or a.name.startswith("navstress."):
                    check(a.name, None, node.lineno)
                    if a.asname:
                        bound[a.asname] = a.name
                    else:
                        bound["navstress"] = "navstress"
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        chain: list[str] = []
        n: ast.expr = node
        while isinstance(n, ast.Attribute):
            chain.append(n.attr)
            n = n.value
        if not (isinstance(n, ast.Name) and n.id in bound):
            continue
        mod = bound[n.id]
        for attr in reversed(chain):
            if f"{mod}.{attr}" in modules:
                mod = f"{mod}.{attr}"
                continue
            if _private(attr):
                check(mod, attr, node.lineno)
            break
    return sorted(set(out))


def test_no_private_name_crosses_a_package() -> None:
    found = [f for m in MODULES for f in private_crossings(m, _source(m), set(MODULES), PACKAGES)]
    assert found == [], "make the name public where it lives (or move it):\n" + "\n".join(found)


def test_the_packages_are_the_top_level_subpackages() -> None:
    assert package_of("navstress.world.export.sdf") == package_of("navstress.world") == "navstress.world"
    assert package_of("navstress._files") == "navstress._files" != package_of("navstress._json")
    assert {package_of(m) for m in MODULES} >= {"navstress.world", "navstress.run", "navstress.sim",
                                                "navstress.analysis", "navstress._files", "navstress"}


_MODS = {"navstress", "navstress._files", "navstress.world", "navstress.world.spec", "navstress.world.export",
         "navstress.world.export._grid", "navstress.world.export.images", "navstress.run", "navstress.run.mission",
         "navstress.run.live", "navstress.nav", "navstress.nav.registry", "navstress.sim", "navstress.sim._step"}
_PKGS = {"navstress", "navstress.world", "navstress.world.export", "navstress.run", "navstress.nav", "navstress.sim"}


@pytest.mark.parametrize("module,code", [
    ("navstress.campaign.spec", "from navstress.world.spec import _to_spec_error"),
    ("navstress.analysis.svgmap", "from navstress.world.export.images import _terrain_cmap, ground_norm"),
    ("navstress.run.trace", "def f():\n    from navstress.world.export._grid import terrain_faces"),
    ("navstress.run.mission", "import navstress.sim._step"),
    ("navstress.run.mission", "from navstress.sim import _step"),
    ("navstress.campaign.executors", "from navstress.nav import registry\nsaved = dict(registry._registered)"),
    ("navstress.isolate", "import navstress.nav.registry as reg\nreg._make_spec('a-v1', 'm:f', 'x')"),
    ("navstress.isolate", "import navstress.nav.registry\nnavstress.nav.registry._registered.clear()"),
    ("navstress.run.batch", "from navstress._files import _write_temp"),
    ("navstress.run.batch", "from navstress import _files\n_files._write_temp(p, b'')"),
    ("navstress.world.spec", "from navstress import _hidden_helper"),
    ("navstress.world.spec", "from .. import _hidden_helper"),
    ("navstress.world.world", "from ..run.mission import _true_pose"),
])
def test_private_crossings_are_found(module: str, code: str) -> None:
    assert len(private_crossings(module, code, _MODS, _PKGS)) == 1, private_crossings(module, code, _MODS, _PKGS)


@pytest.mark.parametrize("module,code", [
    ("navstress.run.live", "from navstress.run.mission import _true_pose"),  # one package
    ("navstress.world.export.images", "from navstress.world.export._grid import MARKER"),
    ("navstress.world.generate", "from navstress.world.spec import _to_spec_error"),
    ("navstress.sim.simulation", "from navstress.sim import _step\n_step._steps(1)"),
    ("navstress.run.trace", "from navstress import _files\n_files.write_atomic(p, b'')"),  # shared internals
    ("navstress.run.trace", "import navstress._jit"),
    ("navstress.analysis.report", "from navstress.world.export.images import terrain_cmap"),
    ("navstress.cli.world", "import numpy as np\nnp._NoValue"),  # not navstress's
    ("navstress.campaign.executors", "from navstress.nav import registry\nregistry.__name__"),
])
def test_what_stays_in_its_package_passes(module: str, code: str) -> None:
    assert private_crossings(module, code, _MODS, _PKGS) == []


# ---- 3. positional parameters ---------------------------------------------------------------

MAX_POSITIONAL = 8


def long_signatures(module: str, source: str, limit: int = MAX_POSITIONAL) -> list[str]:
    """``module:line qualname (n positional)`` for each function over ``limit`` positional
    parameters (rule 3)."""
    out: list[str] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                name = "<lambda>" if isinstance(child, ast.Lambda) else child.name
                pos = [a.arg for a in child.args.posonlyargs + child.args.args]
                if pos and pos[0] in ("self", "cls"):
                    pos = pos[1:]
                if len(pos) > limit:
                    out.append(f"{module}:{child.lineno} {prefix}{name} ({len(pos)} positional)")
                visit(child, f"{prefix}{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return out


def test_no_function_takes_more_than_8_positional_parameters() -> None:
    found = [f for m in MODULES for f in long_signatures(m, _source(m))]
    assert found == [], f"{len(found)} functions over {MAX_POSITIONAL} positional parameters " \
                        "(make the rest keyword-only, or pass a record):\n" + "\n".join(found)


@pytest.mark.parametrize("code,found", [
    ("def f(a, b, c, d, e, f, g, h, i): pass", ["f (9 positional)"]),
    ("def f(a, b, c, d, e, f, g, h, /, i): pass", ["f (9 positional)"]),
    ("class C:\n    def m(self, a, b, c, d, e, f, g, h, i): pass", ["C.m (9 positional)"]),
    ("class C:\n    @classmethod\n    def m(cls, a, b, c, d, e, f, g, h, i): pass", ["C.m (9 positional)"]),
    ("class C:\n    @staticmethod\n    def m(a, b, c, d, e, f, g, h, i): pass", ["C.m (9 positional)"]),
    ("async def f(a, b, c, d, e, f, g, h, i=1): pass", ["f (9 positional)"]),
    ("def outer():\n    def inner(a, b, c, d, e, f, g, h, i): pass", ["outer.inner (9 positional)"]),
    ("k = lambda a, b, c, d, e, f, g, h, i: a", ["<lambda> (9 positional)"]),
    ("def f(a, b, c, d, e, f, g, h): pass", []),  # 8: the limit itself
    ("class C:\n    def m(self, a, b, c, d, e, f, g, h): pass", []),
    ("def f(a, b, c, d, e, f, g, h, *, i, j, k): pass", []),  # keyword-only ones are free
    ("def f(a, b, c, d, e, f, g, h, *rest, **kw): pass", []),
])
def test_long_signatures_are_found(code: str, found: list[str]) -> None:
    assert [f.split(" ", 1)[1] for f in long_signatures("navstress.x", code)] == found


# ---- 4. function-level imports say why ------------------------------------------------------


def unexplained_local_imports(module: str, source: str) -> list[str]:
    """Each import of navstress's own inside a function with no comment on its line, nor a comment
    line just above it (rule 4)."""
    lines = source.splitlines()
    out = []
    tree = ast.parse(source)
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.ImportFrom):
                mod = ("." * node.level) + (node.module or "")
                own = bool(node.level) or mod == "navstress" or mod.startswith("navstress.")
            elif isinstance(node, ast.Import):
                own = any(a.name == "navstress" or a.name.startswith("navstress.") for a in node.names)
            else:
                continue
            said = "#" in lines[node.lineno - 1] or (node.lineno >= 2 and lines[node.lineno - 2].strip().startswith("#"))
            if own and not said:
                out.append(f"{module}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    return out


def test_function_level_imports_of_navstress_say_why() -> None:
    found = [f for m in MODULES for f in unexplained_local_imports(m, _source(m))]
    assert found == [], "import it at the top of the module, or say on its line why it is here:\n" + "\n".join(found)


@pytest.mark.parametrize("code,n", [
    ("def f():\n    from navstress.run.live import LiveSettings\n", 1),
    ("def f():\n    import navstress.world\n", 1),
    ("def f():\n    from . import sibling\n", 1),
    ("def f():\n    from navstress.run.live import LiveSettings  # local: MuJoCo\n", 0),
    ("def f():\n    # here: pyribs takes 2 s to import\n    from navstress.search.algorithms import make\n", 0),
    ("def f():\n    import json\n", 0),  # not navstress's own
    ("from navstress.run.live import LiveSettings\n", 0),  # module level
])
def test_unexplained_local_imports_are_found(code: str, n: int) -> None:
    assert len(unexplained_local_imports("navstress.x", code)) == n
