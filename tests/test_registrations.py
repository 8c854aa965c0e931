"""Every built-in component is registered in one place (core.registry.BUILT_INS), and what each
shipped profile configures resolves, under the numba backend, to the compiled implementation
where the package has one (so ``batch-joint``, say, is in the lazy table: a library user's automotive
profile loads without another module registering it first)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import radarslam
from radarslam.core import registry

SRC = Path(radarslam.__file__).resolve().parent


def test_no_module_of_the_package_registers_a_component_but_the_table():
    calls = []
    for path in SRC.rglob("*.py"):
        if path == SRC / "core" / "registry.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "register"
                    and isinstance(node.func.value, ast.Name) and node.func.value.id.isupper()):
                calls.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert not calls, f"registrations outside core/registry.py BUILT_INS: {calls}"


def test_every_built_in_resolves_to_its_named_factory():
    for reg, name, backend, target in registry.BUILT_INS:
        f = reg.factory(name, backend)
        module, attribute = target.split(":")
        assert f.__module__ == module or getattr(f, "__self__", None) is not None, (name, backend, f)
        assert callable(f)


def test_a_profile_loads_in_a_fresh_process_with_nothing_else_imported():
    """The defect: ``profile_config('automotive')`` named ``batch-joint``, which only importing the
    associators' modules registered; a fresh process refused it."""
    code = ("from radarslam.config import profile_config, list_profiles\n"
            "for p in list_profiles(): profile_config(p)\nprint('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-500:]


@pytest.mark.parametrize("profile", ["apsipa", "automotive", "victoria-park", "reference", "large-carpark",
                                     "victoria-park-trees"])
def test_each_configured_component_is_the_compiled_one_under_numba(profile):
    pytest.importorskip("numba")
    from radarslam.config import profile_config

    cfg = profile_config(profile)
    name = cfg.landmarks.associator
    f = registry.ASSOCIATORS.factory(name, "numba")
    compiled = {n for r, n, b, _ in registry.BUILT_INS if r is registry.ASSOCIATORS and b == "numba"}
    assert name in compiled
    assert f(cfg.estimator).backend == "numba", (profile, name, f.__module__)
    # negative control: the reference backend runs the same kernels in the interpreter
    assert registry.ASSOCIATORS.factory(name, "python")(cfg.estimator).backend == "python"


def test_a_target_without_an_attribute_is_refused_in_one_line():
    from radarslam.core.errors import ConfigError

    r = registry.Registry("toy", "toy.key")
    with pytest.raises(ConfigError, match=r"toy.key: toy 'x': expected 'module:attribute', got 'radarslam.x'"):
        r.register_lazy("x", "radarslam.x")


def test_the_measurement_model_is_the_one_built_in_and_said_plainly():
    """No registry the filter would not use: the filter holds the range-azimuth
    model; filter.measurement_model names it, and another name is refused in one line."""
    from radarslam.config import from_dict, to_dict
    from radarslam.core.errors import ConfigError
    from radarslam.models.radar import RangeAzimuthModel
    from radarslam.slam.filter import EkfSlam

    assert not hasattr(registry, "MEASUREMENT_MODELS")
    base = to_dict(from_dict({}))
    assert isinstance(EkfSlam(from_dict(base)).measurement, RangeAzimuthModel)
    with pytest.raises(ConfigError, match=r"filter\.measurement_model: expected one of \['range-azimuth'\], got 'x'"):
        from_dict({**base, "filter": {**base["filter"], "measurement_model": "x"}})
