"""Imports run one way (read from the source with ``ast``, so a lazy import inside a function counts).

- ``radarslam.metrics`` imports nothing of radarslam but ``radarslam.core`` and itself: metrics take
  plain arrays and never depend on the estimator or the simulator they evaluate;
- ``radarslam.viz`` and ``radarslam.io`` import nothing of the estimation (``slam``, ``landmarks``,
  ``extent``), the simulation or the experiments (``io`` not the CLI either);
- the estimation packages (``slam``, ``landmarks``, ``extent``, ``models``) import nothing of
  ``metrics``, ``io``, ``viz``, the packages that run commands or ``cli``;
- every package imports only packages before it in :data:`ORDER` (docs/architecture.md "Packages"),
  and no file of the tree (``src``, ``scripts``, ``benchmarks``) takes part in a circle of imports.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import radarslam

SRC = Path(radarslam.__file__).resolve().parent

ESTIMATION = ("radarslam.slam", "radarslam.landmarks", "radarslam.extent", "radarslam.models")
#: The packages from the bottom up: each imports only packages before it (the deprecated
#: ``experiments`` shim, which hands over moved modules by name, stands outside).
ORDER = ("core", "config", "landmarks", "extent", "metrics", "io", "models", "viz", "slam", "simulation", "egomotion",
         "compiling", "runs", "montecarlo", "cli")
#: The packages that run what a command does (above the estimation, the simulation and the outputs).
COMMANDS = ("radarslam.egomotion", "radarslam.compiling", "radarslam.runs", "radarslam.montecarlo",
            "radarslam.experiments")
OUTSIDE_ESTIMATION = ("radarslam.metrics", "radarslam.io", "radarslam.viz", "radarslam.cli") + COMMANDS
NOT_FOR_VIZ = ("radarslam.slam", "radarslam.landmarks", "radarslam.extent", "radarslam.simulation") + COMMANDS
NOT_FOR_IO = NOT_FOR_VIZ + ("radarslam.metrics", "radarslam.viz", "radarslam.cli")

#: Known violations, marked xfail(strict=True) one module at a time: ``{module: reason}``. The last
#: one, ``radarslam.extent`` (extent/__init__.py lazily re-exported radarslam.metrics.gwd), is gone.
KNOWN: dict[str, str] = {}


def module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def modules_of(package: str) -> list[tuple[str, Path]]:
    root = SRC.parent.joinpath(*package.split("."))
    return sorted((module_name(p), p) for p in root.rglob("*.py"))


def _is_module(name: str) -> bool:
    """Whether ``name`` is a radarslam module or package in the source tree (nothing is imported)."""
    if not name.startswith("radarslam."):
        return False
    base = SRC.parent.joinpath(*name.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def radarslam_imports(name: str, path: Path, packages_of_submodules: bool = True) -> set[str]:
    """Every ``radarslam...`` module imported anywhere in the file (top level or inside functions).
    ``from P import m`` of a submodule ``m`` counts ``P`` too, unless ``packages_of_submodules`` is
    False (then ``P`` counts only when a name is not a submodule: what the circle check reads, for
    which a package's ``__init__`` re-exporting its modules is no circle)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            subs = [a for a in node.names if _is_module(f"{mod}.{a.name}")]
            out.update(f"{mod}.{a.name}" for a in subs)  # "from radarslam import metrics" imports the subpackage
            if packages_of_submodules or len(subs) < len(node.names):
                out.add(mod)
    return {m for m in out if m == "radarslam" or m.startswith("radarslam.")}


def _inside(mod: str, packages) -> bool:
    return any(mod == p or mod.startswith(p + ".") for p in packages)


def _params(packages, known=None):
    out = []
    for pkg in packages:
        for name, path in modules_of(pkg):
            marks = [pytest.mark.xfail(strict=True, reason=known[name])] if known and name in known else []
            out.append(pytest.param(name, path, id=name, marks=marks))
    return out


def test_the_walk_sees_every_package():
    """The walk is not vacuous: it finds the modules and a known import of each kind."""
    names = {n for pkg in ("radarslam.metrics", "radarslam.viz", "radarslam.io") + ESTIMATION for n, _ in modules_of(pkg)}
    assert {"radarslam.metrics.gwd", "radarslam.metrics.statistics", "radarslam.viz.report", "radarslam.io.results",
            "radarslam.slam.filter", "radarslam.extent", "radarslam.models.radar"} <= names
    gwd = dict(modules_of("radarslam.metrics"))["radarslam.metrics.gwd"]
    assert radarslam_imports("radarslam.metrics.gwd", gwd) == {"radarslam.core.errors", "radarslam.core.validation"}
    viz = dict(modules_of("radarslam.viz"))["radarslam.viz.report"]
    assert "radarslam.viz.carpark" in radarslam_imports("radarslam.viz.report", viz)  # imported inside a function


def test_every_import_form_is_resolved(tmp_path):
    f = tmp_path / "fake.py"
    f.write_text("import numpy\nimport radarslam.core.errors\nfrom radarslam import metrics, __version__\n"
                 "def g():\n    from ..slam import filter\n    from . import carpark\n")
    assert radarslam_imports("radarslam.viz.fake", f) == {
        "radarslam", "radarslam.core.errors", "radarslam.metrics", "radarslam.slam", "radarslam.slam.filter",
        "radarslam.viz", "radarslam.viz.carpark"}


@pytest.mark.parametrize("name, path", _params(["radarslam.metrics"]))
def test_metrics_import_only_core_and_metrics(name, path):
    bad = sorted(m for m in radarslam_imports(name, path) if not _inside(m, ("radarslam.core", "radarslam.metrics")))
    assert not bad, f"{name} imports {bad}"


@pytest.mark.parametrize("name, path", _params(["radarslam.viz"]))
def test_viz_imports_no_estimation_simulation_or_experiments(name, path):
    bad = sorted(m for m in radarslam_imports(name, path) if _inside(m, NOT_FOR_VIZ))
    assert not bad, f"{name} imports {bad}"


@pytest.mark.parametrize("name, path", _params(["radarslam.io"]))
def test_io_imports_no_estimation_simulation_experiments_or_evaluation(name, path):
    bad = sorted(m for m in radarslam_imports(name, path) if _inside(m, NOT_FOR_IO))
    assert not bad, f"{name} imports {bad}"


@pytest.mark.parametrize("name, path", _params(ESTIMATION, KNOWN))
def test_estimation_imports_no_evaluation_output_or_experiments(name, path):
    bad = sorted(m for m in radarslam_imports(name, path) if _inside(m, OUTSIDE_ESTIMATION))
    assert not bad, f"{name} imports {bad}"


def test_numba_cache_stamp_covers_every_compiled_source():
    """Every file with compiled code is stamped (core.numba_cache): the modules that import numba
    and the modules whose kernels compile_kernels compiled."""
    import importlib
    from pathlib import Path

    from conftest import require

    require("numba")
    from radarslam.core import jit, numba_cache

    root = numba_cache.ROOT
    for mod in ("slam._numba", "slam.fused", "extent._compiled", "landmarks._compiled", "metrics._compiled",
                "simulation._compiled"):
        importlib.import_module(f"radarslam.{mod}")
    with_numba = {p.relative_to(root).as_posix() for p in root.rglob("*.py") if "from numba" in p.read_text()}
    kernels = {Path(importlib.import_module(m).__file__).resolve().relative_to(root).as_posix()
               for m in jit.COMPILED_MODULES}
    assert kernels >= {"slam/ekf.py", "core/angles.py", "extent/random_matrix.py"}   # it saw the kernels
    assert with_numba | kernels <= set(numba_cache.COMPILED_SOURCES)


def test_numba_cache_refresh_deletes_stale_machine_code(tmp_path):
    """A changed compiled source deletes the cached code once, with radarslam's markers that say it
    is cached (compiling/markers.py); an unchanged one keeps both."""
    import os

    from radarslam.core import numba_cache

    for rel in numba_cache.COMPILED_SOURCES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("x = 1\n")
    cache = tmp_path / "slam" / "__pycache__"
    cache.mkdir()
    (cache / "_fused.run_stream-1.py311.nbi").write_text("old")
    assert numba_cache.refresh(tmp_path)                       # no stamp yet: cleared, stamped
    assert not (cache / "_fused.run_stream-1.py311.nbi").exists()
    (cache / "_fused.run_stream-1.py311.nbi").write_text("new")
    marker = cache / f"radarslam.slam.fused.engine.engine.locals.run_stream.0123{numba_cache.MARKER_SUFFIX}"
    marker.write_text("{}")
    assert not numba_cache.refresh(tmp_path)                   # nothing changed: kept
    assert (cache / "_fused.run_stream-1.py311.nbi").exists() and marker.exists()
    src = tmp_path / "slam" / "_numba.py"                       # a callee's file changes
    src.write_text("x = 2\n")
    st = src.stat()
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert numba_cache.refresh(tmp_path)
    assert not (cache / "_fused.run_stream-1.py311.nbi").exists() and not marker.exists()


# --- the order of the packages, and no circle anywhere ------------------------------------------

ROOT = Path(__file__).resolve().parents[1]     # the checkout (the package may be installed elsewhere)


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_the_order_names_every_package():
    on_disk = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()} - {"experiments"}
    assert on_disk == set(ORDER), f"ORDER lacks {sorted(on_disk - set(ORDER))} or names gone {sorted(set(ORDER) - on_disk)}"


@pytest.mark.parametrize("package", ORDER)
def test_a_package_imports_only_packages_below_it(package):
    below = set(ORDER[:ORDER.index(package)]) | {package, ""}
    bad = sorted({f"{name} -> {m}" for name, path in modules_of(f"radarslam.{package}")
                  for m in radarslam_imports(name, path) if _package(m) not in below})
    assert not bad, f"upward imports: {bad}"


def test_nothing_imports_the_deprecated_experiments_package():
    users = sorted(name for pkg in ORDER for name, path in modules_of(f"radarslam.{pkg}")
                   if any(_inside(m, ("radarslam.experiments",)) for m in radarslam_imports(name, path)))
    assert not users


def _local_imports(path: Path, local: set[str]) -> set[str]:
    """The modules of ``local`` (the top-level names of a folder's scripts) that ``path`` imports."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out = set()
    for node in ast.walk(tree):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and not node.level and node.module else [])
        out.update(n.split(".")[0] for n in names if n.split(".")[0] in local)
    return out


def import_graph() -> dict[str, set[str]]:
    """Every file of the tree and the files it imports: the package's modules by name (a package's
    ``__init__`` as the package), ``scripts/`` and ``benchmarks/`` by their folder and file name."""
    graph = {name: {m for m in radarslam_imports(name, path, False) if m != name}
             for name, path in modules_of("radarslam")}
    for folder in ("scripts", "benchmarks"):
        files = {p.stem: p for p in (ROOT / folder).glob("*.py")}
        for stem, path in files.items():
            graph[f"{folder}/{stem}"] = ({f"{folder}/{m}" for m in _local_imports(path, set(files)) if m != stem}
                                         | radarslam_imports(stem, path, False))
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one file (Tarjan's algorithm, iterative)."""
    index, low, stack, on, out, n = {}, {}, [], set(), [], 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = n
        n += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = n
                    n += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def test_the_circle_finder_finds_a_circle():
    """Negative control: a made-up graph with one circle of three and a tail."""
    g = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"a"}}
    assert circles(g) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_a_circle_made_in_a_copy_of_the_tree_is_found(tmp_path):
    """Negative control on real files: the resolver reads a lazy import inside a function."""
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text("from radarslam.slam import filter\n")
    b.write_text("def f():\n    from radarslam.slam.filter import EkfSlam\n")
    g = {"radarslam.slam.filter": radarslam_imports("radarslam.slam.filter", b, False) | {"radarslam.slam.x"},
         "radarslam.slam.x": radarslam_imports("radarslam.slam.x", a, False)}
    assert circles(g) == [["radarslam.slam.filter", "radarslam.slam.x"]]


def test_no_circle_of_imports_in_the_whole_tree():
    graph = import_graph()
    assert "scripts/_montecarlo_table" in graph and "radarslam.slam.filter" in graph   # it saw the whole tree
    assert "scripts/_montecarlo_table" in graph["scripts/nees_study"]
    assert not circles(graph), circles(graph)


def test_every_package_is_named_in_the_architecture_document():
    """docs/architecture.md describes today's code: each package in its table, with a purpose."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    table = {line.split("|")[1].strip().strip("`") for line in text.splitlines()
             if line.startswith("| `") and line.count("|") >= 3}
    assert set(ORDER) <= table, f"not in docs/architecture.md's package table: {sorted(set(ORDER) - table)}"
    assert "## The path of one recording" in text and "map.csv" in text
