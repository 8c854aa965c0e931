"""numba's disk cache and two processes saving at once (docs/speed.md "First run"): the interleaving
that sends one entry's key to another entry's machine code when both entries share one index file,
replayed on numba's own cache file class in a temporary folder; and the fused engine's families, each
compiled under a name of its own, so that no two of them share an index."""

from __future__ import annotations

from numba.core.caching import IndexDataCacheFile

from radarslam.slam.fused.engine import Family, engine


def _two_processes(tmp_path, base_a: str, base_b: str):
    """Process A saves ``"family A"`` under key ``ka``, process B ``"family B"`` under ``kb``, each into
    the index of its base name: both read their index before either writes, B's index lands after
    A's and A's data after B's. Returns what a third process loads for each key."""
    a = IndexDataCacheFile(str(tmp_path), base_a, "stamp")
    b = IndexDataCacheFile(str(tmp_path), base_b, "stamp")
    seen_a, seen_b = a._load_index(), b._load_index()          # both read (empty) indexes
    name_a = next(a._data_name(i) for i in range(1, 9) if a._data_name(i) not in seen_a.values())
    name_b = next(b._data_name(i) for i in range(1, 9) if b._data_name(i) not in seen_b.values())
    a._save_index({**seen_a, "ka": name_a})
    b._save_index({**seen_b, "kb": name_b})
    b._save_data(name_b, "family B")
    a._save_data(name_a, "family A")
    third_a = IndexDataCacheFile(str(tmp_path), base_a, "stamp")
    third_b = IndexDataCacheFile(str(tmp_path), base_b, "stamp")
    return third_a.load("ka"), third_b.load("kb")


def test_one_index_for_two_families_loads_the_wrong_code(tmp_path):
    """The cause: one index shared by two keys; key B is then served family A's code."""
    got_a, got_b = _two_processes(tmp_path, "run_stream-108.py311", "run_stream-108.py311")
    assert got_b == "family A"
    assert got_a is None                       # A's entry lost from the index: recompiled, harmless


def test_an_index_for_each_family_never_mixes_them(tmp_path):
    """The same interleaving with an index per family: each key loads its own code."""
    got_a, got_b = _two_processes(tmp_path, "run_stream_view0_jcbb1_bias1-108.py311",
                                  "run_stream_view0_jcbb0_bias1-108.py311")
    assert (got_a, got_b) == ("family A", "family B")


def test_each_family_of_the_fused_engine_has_its_own_index():
    """Every one of the eight families is cached under its own index file name (nothing compiles
    here: the dispatchers are built, not called)."""
    paths = {f: engine(Family(*f))._cache._cache_file._index_path
             for f in [(v, j, b) for v in (False, True) for j in (False, True) for b in (False, True)]}
    assert len(set(paths.values())) == 8, paths
