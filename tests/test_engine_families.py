"""One compiled fused engine per family of configurations (slam/fused/engine.py ``Family``,
docs/architecture.md "Where the compile time goes"): a default configuration's run compiles
neither the partial view's association and sifting, nor JCBB, nor the odometry-bias states'
prediction; the cache keeps each family apart across processes, and the first-run rule asks
about the family a command uses."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from radarslam.config import profile_config
from radarslam.experiments.variants import Variant, apply_variant
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam

from conftest import require

#: A cold process: the default variants' and the consistent one's run (nearest neighbour and
#: batch-joint, the default family), then what numba compiled of the other families' code.
COLD = """
import json
from radarslam.config import profile_config
from radarslam.experiments.single import run_filter
from radarslam.experiments.variants import DEFAULT_VARIANTS, apply_variant
from radarslam.experiments.warmup import _tiny_stream
from radarslam.slam import _fused, _numba, _jcbb_numba
from radarslam.slam.fused import bias, view
from radarslam.extent import _compiled as extent_compiled
for v in DEFAULT_VARIANTS:
    run_filter(apply_variant(profile_config(), v), _tiny_stream())
n = lambda d: len(d.signatures)
print(json.dumps({
    "engine": n(_fused.engine(_fused.DEFAULT)),
    "nearest": n(_numba.associate_scan), "joint": n(_numba.joint_batch_associate_scan),
    "view_associate": n(view.view_associate), "view_terms": n(view.view_terms), "view_sift": n(view.view_sift),
    "view_rows": n(extent_compiled.view_rows), "jcbb": n(_jcbb_numba.jcbb_associate_scan),
    "bias": n(bias._platform_prediction),
    "others": [n(_fused.engine(f)) for f in (_fused.Family(True, False, False), _fused.Family(False, True, False),
                                             _fused.Family(False, False, True))],
}))
"""

#: A second process on the same cache: what the first-run rule reads from disk.
WARM = """
import json
from radarslam.experiments import first_run, warmup
from radarslam.experiments.single import run_filter
from radarslam.config import profile_config
from radarslam.slam import _fused
view = _fused.Family(True, False, False)
out = {"default_ready": first_run._filter_ready(), "view_ready": first_run._filter_ready(view),
       "both_ready": first_run._filter_ready(_fused.DEFAULT, view), "fused_cold": warmup.fused_is_cold(),
       "view_cold": warmup.fused_is_cold(view)}
run_filter(profile_config(), warmup._tiny_stream())
out["hits"] = sum(_fused.engine(_fused.DEFAULT).stats.cache_hits.values())
out["misses"] = sum(_fused.engine(_fused.DEFAULT).stats.cache_misses.values())
print(json.dumps(out))
"""


def _python(code: str, cache) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_default_run_compiles_its_family_alone_and_the_cache_keeps_families_apart(tmp_path):
    """Cold (an empty NUMBA_CACHE_DIR): the default family's engine and its associators compile,
    the partial view's association, sifting and shapes, JCBB and the bias states' prediction do
    not, nor another family's engine (before the cut, one engine compiled them all). Warm (a second
    process on that cache): the default family is ready and loads from disk without compiling; the
    partial view's is not, alone or beside the default."""
    require("numba")
    cold = _python(COLD, tmp_path / "cache")
    assert cold["engine"] == 1 and cold["nearest"] == 1 and cold["joint"] == 1        # what the default runs
    for name in ("view_associate", "view_terms", "view_sift", "view_rows", "jcbb", "bias"):
        assert cold[name] == 0, name
    assert cold["others"] == [0, 0, 0]
    warm = _python(WARM, tmp_path / "cache")
    assert warm["default_ready"] is True and warm["fused_cold"] is False
    assert warm["view_ready"] is False and warm["both_ready"] is False and warm["view_cold"] is True
    assert warm["hits"] == 1 and warm["misses"] == 0


def test_each_configuration_names_its_family():
    """The family :func:`run` compiles for (plan.family) and the one the first-run rule asks about
    (warmup.fused_families): the default for the car parks' variants, the automotive profile and
    Victoria Park; its own for the partial view, JCBB and the bias states."""
    from radarslam.experiments.warmup import fused_families
    from radarslam.experiments.variants import DEFAULT_VARIANTS

    cfg = profile_config()
    assert fused_families(cfg, DEFAULT_VARIANTS) == ()
    for name in ("automotive", "victoria-park"):
        assert fused_families(profile_config(name)) == (), name
    view = {"extent": {"use_in_slam": True, "spread_model": "visible-faces"}}
    cases = {"view": (view, _fused.Family(True, False, False)),
             "jcbb": ({"landmarks": {"associator": "jcbb"}}, _fused.Family(False, True, False)),
             "bias": ({"filter": {"odometry_bias": "states"}}, _fused.Family(False, False, True))}
    for name, (overlay, family) in cases.items():
        v = Variant(name, name, overlay)
        slam = EkfSlam(apply_variant(cfg, v))
        assert _fused.why_not(slam) is None, name
        assert _fused.family(slam) == family, name
        assert fused_families(cfg, (v,)) == (family,), name
        assert fused_families(cfg, (DEFAULT_VARIANTS[0], v)) == tuple(sorted((_fused.DEFAULT, family))), name


def test_a_step_compiled_only_for_compiled_callers_refuses_a_python_call_in_one_line():
    """core.jit.compiled_only: a fused step built without a Python entry point raises a TypeError that
    names it, instead of jumping to an address that was never built; a kernel with its entry point
    (negative control) still runs from Python."""
    import numpy as np
    import pytest

    from radarslam.core.jit import CompiledOnly
    from radarslam.slam.fused import mapping, storage

    assert isinstance(mapping.augment, CompiledOnly) and isinstance(storage.record_map, CompiledOnly)
    with pytest.raises(TypeError, match=r"^radarslam\.slam\.fused\.mapping\.augment is compiled without a Python "
                                        r"entry point \(core\.jit\.compiled_only\)"):
        mapping.augment(1, 2)
    from radarslam.landmarks._compiled import compiled_grown

    assert not isinstance(compiled_grown, CompiledOnly)
    assert compiled_grown(np.zeros(2), 3).shape[0] >= 3
