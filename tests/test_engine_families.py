"""One compiled fused engine per family of configurations (slam/fused/engine.py ``Family``,
docs/architecture.md "Where the compile time goes"): a default configuration's run compiles
neither the partial view's association and sifting, nor JCBB, nor the odometry-bias states'
prediction; the cache keeps each family apart across processes, and the first-run rule asks
about the family a command uses."""

from __future__ import annotations

from radarslam.config import profile_config
from radarslam.config.variants import Variant, apply_variant
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam

import family_evidence
from conftest import require


def test_a_default_run_compiles_its_family_alone_and_the_cache_keeps_families_apart(tmp_path, family_evidence_path):
    """Cold (an empty NUMBA_CACHE_DIR): the default family's engine and its associators compile,
    the partial view's association, sifting and shapes, JCBB and the bias states' prediction do
    not, nor another family's engine (before the cut, one engine compiled them all). Warm (a second
    process on that cache): the default family is ready and loads from disk without compiling; the
    partial view's is not, alone or beside the default. Measured by the session's warm-up when it
    met a cold cache (a fresh clone: the one cold compile serves both), else here on an empty cache
    (tests/family_evidence.py)."""
    require("numba")
    evidence = family_evidence.read(family_evidence_path)
    if evidence is None:        # this session's cache was warm: measure on an empty cache of our own
        cold = family_evidence.python(family_evidence.COLD, tmp_path / "cache")
        warm = family_evidence.python(family_evidence.WARM, tmp_path / "cache")
    else:                       # the session's warm-up compiled the default family cold (conftest.py)
        cold, warm = evidence
    assert cold["engine"] == 1 and cold["nearest"] == 1 and cold["joint"] == 1        # what the default runs
    for name in ("view_associate", "view_terms", "view_sift", "view_rows", "jcbb", "bias"):
        assert cold[name] == 0, name
    assert cold["others"] == [0, 0, 0]
    assert warm["default_ready"] is True and warm["fused_cold"] is False
    assert warm["view_ready"] is False and warm["both_ready"] is False and warm["view_cold"] is True
    assert warm["hits"] == 1 and warm["misses"] == 0


def test_each_configuration_names_its_family():
    """The family :func:`run` compiles for (plan.family) and the one the first-run rule asks about
    (readiness.fused_families): the default for the car parks' variants, the automotive profile and
    Victoria Park; its own for the partial view, JCBB and the bias states."""
    from radarslam.compiling.readiness import fused_families
    from radarslam.config.variants import DEFAULT_VARIANTS

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
