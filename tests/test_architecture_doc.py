"""docs/architecture.md names only what exists: every module path it gives (``slam/fused/plan.py``,
``io/datasets/victoria_park/``, ``radarslam.core.registry``) is a file or folder of the source, and
every name it places in a module (``slam/fused/plan.py: first_carry``, ``plan.py: _stream_arrays``,
``warmup.first_run_engine``, ``EkfSlam.update``, ``step_all()``) is defined there. The source is read
with ``ast``, never imported, so the check costs no compile and no heavy import.

What counts as defined in a module: its top-level functions, classes and assignments (inside
top-level ``if``/``try`` too), functions nested in its functions (the fused engine's ``run_stream`` is
a closure of ``engine``), and its classes' members (methods, class attributes, fields, and the
``self.X`` a method assigns). A package's ``__init__.py`` counts what it imports too (its re-exports
are its interface); any other module's imports do not, so a name the doc places in a module that
only imports it from elsewhere is reported."""

from __future__ import annotations

import ast
import importlib.util
import re
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "radarslam"
DOC = ROOT / "docs" / "architecture.md"

#: The configuration's sections: ``filter.fused`` and ``extent.efa_mode`` are keys, not modules.
CONFIG_SECTIONS = {"trajectory", "odometer", "radar", "world", "filter", "landmarks", "extent", "metrics", "sensor"}
#: Folders of the repository (a path starting with one is taken from the root, not from src/radarslam).
ROOT_DIRS = ("src/", "tests/", "scripts/", "benchmarks/", "docs/", "examples/", ".ci/")
IDENT = r"[A-Za-z_]\w*"
#: A code span ending so is a file's name (``map.csv``, ``plan.py``), not a dotted name.
FILE_SUFFIX = re.compile(r"\.(py|csv|json|toml|md|txt|png|gif|npz|h5|mat|zip|bag|log|ready|nbi|nbc|pcd)$")
#: Dotted names of the package that are not modules: the entry-point group of plugins.
NOT_MODULES = {"radarslam.plugins"}


# --- what the source defines ---------------------------------------------------------------------

def _targets(node) -> list[str]:
    """The names an assignment target binds (``a``, ``a, b``, ``self.a`` is not one)."""
    if isinstance(node, ast.Name):
        return [node.id]
    if isinstance(node, (ast.Tuple, ast.List)):
        return [n for elt in node.elts for n in _targets(elt)]
    return []


def _body_names(body, imports: bool) -> set[str]:
    """The names a module's (or a class's) body binds, through ``if``/``try``/``with`` blocks."""
    names: set[str] = set()
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names.update(n for t in node.targets for n in _targets(t))
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            names.update(_targets(node.target))
        elif imports and isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.If):
            names |= _body_names(node.body, imports) | _body_names(node.orelse, imports)
        elif isinstance(node, ast.Try):
            names |= _body_names(node.body, imports) | _body_names(node.orelse, imports)
            names |= _body_names(node.finalbody, imports)
            for h in node.handlers:
                names |= _body_names(h.body, imports)
        elif isinstance(node, ast.With):
            names |= _body_names(node.body, imports)
    return names


def _class_members(cls: ast.ClassDef) -> set[str]:
    """A class's methods, attributes and fields, and every ``self.X`` its methods assign."""
    names = _body_names(cls.body, imports=False)
    for node in ast.walk(cls):
        targets = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            targets = [node.target]
        for t in targets:
            for sub in ast.walk(t):
                if isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name) and sub.value.id == "self":
                    names.add(sub.attr)
    return names


@lru_cache(maxsize=None)
def definitions(path: Path) -> tuple[frozenset[str], dict[str, frozenset[str]]]:
    """(the names defined in the module at ``path``, {class name: its members}), read with ``ast``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names = _body_names(tree.body, imports=path.name == "__init__.py")
    classes: dict[str, frozenset[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names.add(node.name)                         # nested functions: closures are defined here too
        elif isinstance(node, ast.ClassDef):
            classes[node.name] = frozenset(_class_members(node) | set(classes.get(node.name, ())))
    return frozenset(names), classes


@lru_cache(maxsize=None)
def modules() -> tuple[Path, ...]:
    return tuple(sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts))


def modules_named(rel: str) -> list[Path]:
    """The source files a doc's module path names: ``slam/fused/plan.py`` exactly (from src/radarslam),
    ``fused/plan.py`` or ``plan.py`` by the end of their path."""
    exact = SRC / rel
    if exact.is_file():
        return [exact]
    return [p for p in modules() if p.as_posix().endswith("/" + rel)]


def defined_in(path: Path, dotted: str) -> bool:
    """``name`` or ``Class.member`` is defined in the module at ``path`` (for a package, its
    ``__init__.py`` or a submodule of that name); a bare name may also be a member of one of its
    classes (``state.set`` is ``SlamState.set`` of slam/state.py)."""
    first, _, rest = dotted.partition(".")
    if path.name == "__init__.py" and ((path.parent / f"{first}.py").is_file() or (path.parent / first).is_dir()):
        sub = path.parent / f"{first}.py"
        if not rest:
            return True
        return defined_in(sub if sub.is_file() else path.parent / first / "__init__.py", rest)
    names, classes = definitions(path)
    if not rest:
        return first in names or any(first in members for members in classes.values())
    if first in classes:
        member = rest.split(".")[0]
        return member in classes[first]
    return False


@lru_cache(maxsize=None)
def defined_anywhere(name: str) -> bool:
    return any(defined_in(p, name) for p in modules())


def classes_named(name: str) -> list[Path]:
    return [p for p in modules() if name in definitions(p)[1]]


# --- what the doc names --------------------------------------------------------------------------

def _prose(text: str) -> str:
    """The text without its fenced code blocks (the examples of code of your own)."""
    return re.sub(r"```.*?```", "", text, flags=re.S)


def _spans(text: str) -> list[str]:
    """The contents of the inline code spans (which may wrap over a line)."""
    return [" ".join(s.split()) for s in re.findall(r"`([^`]+)`", _prose(text))]


def _names(listed: str) -> list[str]:
    """``enter_frame, leave_frame, frame_first`` or ``plan(config, workload)`` -> the names."""
    listed = re.sub(r"\([^()]*\)", "", re.sub(r"\([^()]*\)", "", listed))       # arguments, nested once
    out = []
    for part in re.split(r",|\band\b", listed):
        m = re.match(rf"\s*({IDENT}(?:\.{IDENT})*)", part)
        if m:
            out.append(m.group(1))
    return out


PATH = re.compile(r"(?<![\w./$~-])((?:[\w-]+/)+(?:[\w-]+\.(?:py|toml))?|[\w-]+\.py)(?![\w/-])")
MODULE_NAMES = re.compile(rf"^({IDENT}(?:/{IDENT})*(?:\.py)?|(?:\w+/)+__init__\.py):\s+(.+)$")
OUTSIDE_NAMES = re.compile(rf"`((?:{IDENT}/)*{IDENT}\.py)`:\s*((?:`[^`]+`(?:\s*\([^)]*\))?(?:,\s*|\s+and\s+)?)+)")
DOTTED = re.compile(rf"^((?:{IDENT}\.)+{IDENT})(?:\(.*)?$")
CALL = re.compile(rf"^({IDENT})\(.*\)")


def references(text: str) -> list[tuple[str, str, str]]:
    """Every reference the doc makes, as (kind, module or path, name): ``("path", "slam/fused/",
    "")``, ``("in", "slam/fused/plan.py", "first_carry")``, ``("dotted", "", "warmup.first_run_engine")``,
    ``("call", "", "step_all")``."""
    refs: list[tuple[str, str, str]] = []
    for span in _spans(text):
        for p in PATH.findall(span):
            refs.append(("path", p, ""))
        m = MODULE_NAMES.match(span)
        if m and (m.group(1).endswith(".py") or "/" in m.group(1)):
            mod = m.group(1) if m.group(1).endswith(".py") else m.group(1) + ".py"
            refs.extend(("in", mod, n) for n in _names(m.group(2)))
            continue
        m = DOTTED.match(span)
        if m and not FILE_SUFFIX.search(m.group(1)) and m.group(1) not in NOT_MODULES:
            refs.append(("dotted", "", m.group(1)))
            continue
        m = CALL.match(span)
        if m:
            refs.append(("call", "", m.group(1)))
    for mod, listed in OUTSIDE_NAMES.findall(" ".join(_prose(text).split())):
        refs.extend(("in", mod, n) for n in _names(listed.replace("`", "")))
    return refs


def _dotted_problem(dotted: str) -> str | None:
    """Why ``a.b.c`` names nothing of the source, or None (also for a config key or another library)."""
    parts = dotted.split(".")
    if parts[0] == "radarslam":
        parts = parts[1:]
        if not parts:
            return None
    first = parts[0]
    # a module path from the package's root: core.jit.compile_kernels, radarslam.core.registry
    base, i = SRC, 0
    while i < len(parts) and ((base / parts[i]).is_dir() or (base / f"{parts[i]}.py").is_file()):
        base = base / parts[i]
        i += 1
    if i > 0 and not (first in CONFIG_SECTIONS and i == 1):
        if i == len(parts):
            return None
        path = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
        rest = ".".join(parts[i:])
        return None if defined_in(path, rest) else f"{dotted}: {rest} is not defined in {path.relative_to(SRC)}"
    if first in CONFIG_SECTIONS:
        return None                                           # a configuration key: filter.fused
    # a module by its own name: warmup.first_run_engine, ekf.update, odometry_source.DopplerOdometry
    found = modules_named(f"{first}.py") + modules_named(f"{first}/__init__.py")
    if found:
        rest = ".".join(parts[1:])
        if any(defined_in(p, rest) for p in found):
            return None
        return f"{dotted}: {rest} is not defined in {', '.join(str(p.relative_to(SRC)) for p in found)}"
    # a module's constant and a method of its class: ASSOCIATORS.register
    if first.isupper():
        found = [p for p in modules() if first in definitions(p)[0]]
        if not found:
            return f"{dotted}: no constant {first} in src/radarslam"
        if any(parts[1] in members for p in found for members in definitions(p)[1].values()):
            return None
        return f"{dotted}: no class of {first}'s module has a member {parts[1]}"
    # a class and its member: EkfSlam.update, Mounting.from_rig_config
    if first[:1].isupper():
        found = classes_named(first)
        if not found:
            return f"{dotted}: no class {first} in src/radarslam"
        member = parts[1]
        if any(member in definitions(p)[1][first] for p in found):
            return None
        return f"{dotted}: {first} has no member {member}"
    if importlib.util.find_spec(first) is not None:
        return None                                           # another library: dataclasses.replace
    return f"{dotted}: no module {first} in src/radarslam"


def problems(text: str) -> list[str]:
    """Every reference of ``text`` (Markdown) to the source that does not hold, one line each."""
    out: list[str] = []
    for kind, where, name in references(text):
        if kind == "path":
            root = ROOT if where.startswith(ROOT_DIRS) else SRC
            exists = (root / where).exists() or (not where.startswith(ROOT_DIRS) and bool(
                [p for p in SRC.rglob(where.rstrip("/")) if "__pycache__" not in p.parts]))
            if not exists:
                out.append(f"{where}: no such file or folder")
        elif kind == "in":
            found = modules_named(where)
            if not found:
                out.append(f"{where}: no such module (for {name})")
            elif not any(defined_in(p, name) for p in found):
                out.append(f"{where}: {name} is not defined there")
        elif kind == "dotted":
            p = _dotted_problem(name)
            if p:
                out.append(p)
        elif kind == "call" and not defined_anywhere(name):
            out.append(f"{name}(): not defined in src/radarslam")
    return sorted(set(out))


# --- the tests -----------------------------------------------------------------------------------

def test_architecture_doc_names_only_what_exists():
    """Every module, function, class and constant docs/architecture.md names is in the source."""
    text = DOC.read_text(encoding="utf-8")
    refs = references(text)
    assert sum(k == "in" for k, _, _ in refs) >= 40 and sum(k == "path" for k, _, _ in refs) >= 40, len(refs)
    bad = problems(text)
    assert not bad, "\n".join(bad)


def test_the_check_finds_a_missing_module_and_a_missing_function():
    """Negative control: a module that does not exist, a function its module does not define, a
    closure of a module and an existing function in every form the doc uses."""
    text = ("The plan (`slam/fused/plan.py: first_carry, no_such_check`) and `slam/no_such_module.py`.\n"
            "The engine (`slam/fused/engine.py: run_stream`, `engine.py: engine`), `cli/recording.py`,\n"
            "`radarslam.slam.filter`, `EkfSlam.update`, `EkfSlam.no_such_method`, `filter.fused`,\n"
            "`warmup.no_such_warmup`, `plan(config, workload)`, `no_such_call()`, `dataclasses.replace(x)`\n"
            "and `models/radar.py`: `measure`, `no_such_measure`.\n"
            "```python\nnot_checked = `slam/in_code.py: x`\n```\n")
    assert problems(text) == [
        "EkfSlam.no_such_method: EkfSlam has no member no_such_method",
        "models/radar.py: no_such_measure is not defined there",
        "no_such_call(): not defined in src/radarslam",
        "slam/fused/plan.py: no_such_check is not defined there",
        "slam/no_such_module.py: no such file or folder",
        "warmup.no_such_warmup: no_such_warmup is not defined in compiling/warmup.py",
    ]


def test_the_check_reads_a_name_only_imported_as_not_defined(tmp_path, monkeypatch):
    """A name that a module only imports from another is not defined in it (a moved function whose
    old home re-imports it is reported); a package's __init__ re-exports count."""
    pkg = tmp_path / "radarslam" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("from radarslam.pkg.home import moved\n")
    (pkg / "home.py").write_text("def moved():\n    pass\n")
    (pkg / "old.py").write_text("from radarslam.pkg.home import moved\n")
    monkeypatch.setattr(__import__(__name__), "SRC", tmp_path / "radarslam")
    modules.cache_clear()
    try:
        assert problems("`pkg/home.py: moved` `pkg/__init__.py: moved` `pkg/old.py: moved`") == [
            "pkg/old.py: moved is not defined there"]
    finally:
        modules.cache_clear()
