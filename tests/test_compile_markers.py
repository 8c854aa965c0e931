"""radarslam's markers of what numba's cache holds (compiling/markers.py, docs/speed.md "First run").

Each property is checked in fresh interpreters on a NUMBA_CACHE_DIR of the test's own, on a tiny
package of kernels copied to a temporary folder (a plain kernel and two closures of one function,
as the fused engine's families are), and each against numba itself: where a marker says the code is
cached numba loads it (a cache hit), where it says not numba compiles it (none).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import require

import radarslam

SRC = Path(radarslam.__file__).resolve().parents[1]

KERNELS = '''from numba import njit


@njit(cache=True)
def double(x):
    return 2.0 * x


def family(flag):
    @njit(cache=True)
    def shift(x):
        return x + 1.0 if flag else x - 1.0
    return shift


one = family(True)
other = family(False)
'''

# Readiness of the three kernels before anything runs, then the kernels named on the command line
# called (compiled or loaded) with numba's cache hits, then mark() of all three.
PROBE = '''
import json, sys
import kpkg.kernels as k
from radarslam.compiling import markers, readiness
names = ("double", "one", "other")
out = {"fresh": {n: readiness.has_fresh_code(getattr(k, n)) for n in names}}
calls = [a for a in sys.argv[1:] if a != "--no-mark"]
for n in calls:
    getattr(k, n)(1.0)
out["hits"] = {n: sum(getattr(k, n).stats.cache_hits.values()) for n in calls}
out["written"] = 0 if "--no-mark" in sys.argv else markers.mark(*(getattr(k, n) for n in names))
print(json.dumps(out))
'''


@pytest.fixture
def kernels(tmp_path):
    """A package ``kpkg`` of kernels in ``tmp_path / "site"``, and a runner of :data:`PROBE` in a
    fresh interpreter on the numba cache ``tmp_path / "cache"``."""
    require("numba")
    site = tmp_path / "site"
    (site / "kpkg").mkdir(parents=True)
    (site / "kpkg" / "__init__.py").write_text("")
    (site / "kpkg" / "kernels.py").write_text(KERNELS)
    cache = tmp_path / "cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join([str(site), str(SRC)]))

    def probe(*args: str, code: str = PROBE) -> dict:
        out = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                             check=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    probe.site, probe.cache = site, cache
    return probe


def test_a_compiled_and_marked_kernel_is_warm_in_a_fresh_process(kernels):
    """No marker: cold. Compiled and marked in one process: warm in the next, where numba indeed
    loads it from its cache. Negative control: a kernel never called is not marked by mark()."""
    first = kernels("double")
    assert first["fresh"] == {"double": False, "one": False, "other": False}
    assert first["hits"] == {"double": 0} and first["written"] == 1          # compiled here; `one`, `other` not
    second = kernels("double")
    assert second["fresh"] == {"double": True, "one": False, "other": False}
    assert second["hits"] == {"double": 1} and second["written"] == 0        # numba loaded it; already marked
    assert list(kernels.cache.rglob("kpkg.kernels.double.*.ready"))         # beside numba's own files
    assert {p.parent for p in kernels.cache.rglob("*.ready")} == {p.parent for p in kernels.cache.rglob("*.nbi")}


def test_a_compiled_kernel_without_its_marker_is_cold(kernels):
    """Negative control of the marker itself: numba has the code cached, but no marker was written
    (the process did not mark): readiness says cold (a first run then compiles or loads; never wrong)."""
    assert kernels("double", "--no-mark")["written"] == 0
    again = kernels("double")
    assert again["fresh"]["double"] is False and again["hits"] == {"double": 1}


def test_an_edited_source_makes_the_marker_stale(kernels):
    """The source changed after the marker was written: cold, as numba (it compiles again: no hit);
    marked again after that compile, warm."""
    kernels("double")
    path = kernels.site / "kpkg" / "kernels.py"
    path.write_text(path.read_text().replace("2.0 * x", "3.0 * x"))
    edited = kernels("double")
    assert edited["fresh"]["double"] is False and edited["hits"] == {"double": 0} and edited["written"] == 1
    assert kernels()["fresh"]["double"] is True


def test_a_rewritten_unchanged_source_agrees_with_numba(kernels):
    """The same bytes written again (a new modification time): the marker stays fresh exactly when
    numba still loads the code (numba 0.68 on stamps the content, before the modification time)."""
    kernels("double")
    path = kernels.site / "kpkg" / "kernels.py"
    text = path.read_text()
    st = path.stat()
    path.write_text(text)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 5 * 10**9))
    again = kernels("double", "--no-mark")
    assert again["fresh"]["double"] is (again["hits"]["double"] > 0)


def test_another_familys_marker_does_not_make_this_family_warm(kernels):
    """Two closures of one function (one source, one name, one line) differ only by their closure's
    value: the marker of one leaves the other cold, as numba's cache does (it compiles the other)."""
    first = kernels("one")
    assert first["written"] == 1
    second = kernels("other")
    assert second["fresh"] == {"double": False, "one": True, "other": False}
    assert second["hits"] == {"other": 0}
    assert kernels()["fresh"] == {"double": False, "one": True, "other": True}


def test_clearing_the_cache_directory_makes_it_cold_again(kernels):
    """The markers live in numba's cache directory: deleting it makes every kernel cold again."""
    kernels("double", "one")
    assert kernels()["fresh"] == {"double": True, "one": True, "other": False}
    shutil.rmtree(kernels.cache)
    assert kernels()["fresh"] == {"double": False, "one": False, "other": False}


def test_a_process_marks_its_watched_dispatchers_at_exit(kernels):
    """The exit hook (readiness.mark_compiled): a watched kernel compiled in a process that never
    calls mark() itself is warm in the next one. Negative control: the same without it watched."""
    code = '''
import json, sys
import kpkg.kernels as k
from radarslam.compiling import readiness
if sys.argv[1] == "watch":
    readiness.WATCHED = (("kpkg.kernels", "double"),)
k.double(1.0)
print(json.dumps({}))
'''
    kernels("unwatched", code=code)
    assert kernels()["fresh"]["double"] is False
    kernels("watch", code=code)
    assert kernels()["fresh"]["double"] is True


def test_readiness_of_what_is_no_dispatcher_cannot_be_told():
    """A plain function (NUMBA_DISABLE_JIT, a Python kernel) is no dispatcher: None, and nothing is marked."""
    require("numba")
    from radarslam.compiling import markers, readiness
    from radarslam.landmarks.confirmation import rule12

    assert readiness.has_fresh_code(rule12) is None and markers.mark(rule12) == 0


def test_every_dispatcher_the_policy_asks_about_is_watched(monkeypatch):
    """What the plans of every workload ask about is what a process marks (readiness.watched):
    otherwise it would stay cold however often it compiled. Negative control: the asking is seen."""
    require("numba")
    from radarslam.compiling import policy, readiness
    from radarslam.config import profile_config
    from radarslam.config.variants import DEFAULT_VARIANTS

    asked: list = []
    cfg = profile_config()
    for answer in (False, True):          # all cold, then all ready: every branch of the plans asks
        monkeypatch.setattr(readiness, "has_fresh_code", lambda d: asked.append(d) or answer)
        for w in (policy.Workload("trial", simulation=True, matching=True),
                  policy.Workload("trials", n_trials=10, jobs=2, variants=tuple(DEFAULT_VARIANTS)),
                  policy.Workload("stream", n_scans=100), policy.Workload("stream", n_scans=100, fused=False)):
            policy.plan(cfg, w)
    watched = {id(d) for d in readiness.watched()}
    assert asked and {id(d) for d in asked} <= watched
    names = {f"{d.py_func.__module__}.{d.py_func.__name__}" for d in asked}
    assert {"radarslam.landmarks.confirmation.mn_windows", "radarslam.extent.rows.merge_rows",
            "radarslam.simulation._compiled.simulate_scans", "radarslam.metrics._compiled.match_scans"} <= names
