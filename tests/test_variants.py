"""Configuration variants: overlays, validation, the command-line form and the manifest form."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import pytest

from radarslam.config import profile_config, to_dict
from radarslam.core.errors import ConfigError, InputError
from radarslam.config.variants import (DEFAULT_VARIANTS, PAPER_VARIANTS, Variant, apply_variant, check_variants, overlay_to_toml, parse_variant_arg, variants_from_json, variants_to_json)


def test_default_variants_are_the_papers_two_and_the_consistent_one():
    cfg = profile_config("reference")
    for v, use in zip(PAPER_VARIANTS, (False, True)):
        expected = dataclasses.replace(cfg, extent=dataclasses.replace(cfg.extent, use_in_slam=use))
        assert apply_variant(cfg, v) == expected
    assert DEFAULT_VARIANTS[:2] == PAPER_VARIANTS and [v.name for v in DEFAULT_VARIANTS] == ["noext", "ext", "consistent"]
    c = apply_variant(cfg, DEFAULT_VARIANTS[2])
    assert c.extent.use_in_slam and c.extent.pre_init_spread == "prior"
    assert c.landmarks.init == "cluster" and c.landmarks.associator == "batch-joint"
    assert c.trajectory == cfg.trajectory and c.radar == cfg.radar   # same simulated data


def test_overlay_is_deep_merged_and_leaves_everything_else():
    cfg = profile_config()
    v = Variant("abl", "ablation", {"extent": {"use_in_slam": True, "contour_sifting": False},
                                    "landmarks": {"merge_axis_tol_m": 0.5}})
    got = apply_variant(cfg, v)
    a, b = to_dict(cfg), to_dict(got)
    changed = {(s, k) for s in a if isinstance(a[s], dict) for k in a[s] if a[s][k] != b[s][k]}
    assert changed == {("extent", "use_in_slam"), ("extent", "contour_sifting"), ("landmarks", "merge_axis_tol_m")}
    assert got.extent.use_in_slam is True and got.extent.contour_sifting is False
    assert got.landmarks.merge_axis_tol_m == 0.5
    assert cfg.extent.use_in_slam is False and math.isinf(cfg.landmarks.merge_axis_tol_m)  # input untouched


@pytest.mark.parametrize("overlay, key", [({"extent": {"no_such_key": 1}}, "extent.no_such_key"),
                                          ({"extent": {"use_in_slam": 1}}, "extent.use_in_slam"),
                                          ({"filter": {"range_std_m": -1.0}}, "filter.range_std_m"),
                                          ({"extent": True}, "extent")])
def test_bad_overlay_key_names_variant_and_dotted_key(overlay, key):
    with pytest.raises(ConfigError) as ei:
        apply_variant(profile_config(), Variant("bad", "Bad", overlay))
    msg = str(ei.value)
    assert msg.startswith(f"variant 'bad': {key}:") and "\n" not in msg


@pytest.mark.parametrize("section", ["trajectory", "odometer", "radar", "world", "profile"])
def test_overlay_may_not_change_the_simulated_data(section):
    with pytest.raises(InputError, match=f"variant 'x' overlay: .*got key '{section}'"):
        Variant("x", "X", {section: {}})


@pytest.mark.parametrize("name", ["", "Ext", "-a", "a b", "a.b", "trials", "config", "change_pct", "change_pct_ext",
                                  "metric", "paper_ext", "band_low"])
def test_bad_names_are_refused(name):
    with pytest.raises(InputError, match="variant name"):
        Variant(name, "label", {})


def test_check_variants_refuses_duplicates_and_empty():
    with pytest.raises(InputError, match="'ext' twice"):
        check_variants(DEFAULT_VARIANTS + (Variant("ext", "again", {}),))
    with pytest.raises(InputError, match="at least one"):
        check_variants(())
    assert check_variants(list(DEFAULT_VARIANTS)) == DEFAULT_VARIANTS


def test_variant_is_immutable_and_owns_its_overlay():
    overlay = {"extent": {"use_in_slam": True}}
    v = Variant("a", "A", overlay)
    overlay["extent"]["use_in_slam"] = False
    assert v.overlay == {"extent": {"use_in_slam": True}}
    with pytest.raises(dataclasses.FrozenInstanceError):
        v.name = "b"


def test_parse_variant_arg(tmp_path):
    f = tmp_path / "nosift.toml"
    f.write_text('label = "With extent, no sifting"\n[extent]\nuse_in_slam = true\ncontour_sifting = false\n')
    v = parse_variant_arg(f"nosift={f}")
    assert v == Variant("nosift", "With extent, no sifting", {"extent": {"use_in_slam": True, "contour_sifting": False}})
    g = tmp_path / "g.toml"
    g.write_text("[landmarks]\nbeta = 3.0\n")
    assert parse_variant_arg(f"b3={g}").label == "b3"  # label defaults to the name
    assert apply_variant(profile_config(), parse_variant_arg(f"b3={g}")).landmarks.beta == 3.0


@pytest.mark.parametrize("text, match", [("nosift", "expected NAME=FILE.toml"), ("Bad={f}", "expected a NAME"),
                                         ("a={missing}", "no such file"), ("a={bad}", "not valid TOML"),
                                         ("a={sim}", "got key 'world'"), ("a={lab}", "label: expected a string")])
def test_parse_variant_arg_errors(tmp_path, text, match):
    f = tmp_path / "f.toml"
    f.write_text("[extent]\nuse_in_slam = true\n")
    bad = tmp_path / "bad.toml"
    bad.write_text("[extent\n")
    sim = tmp_path / "sim.toml"
    sim.write_text("[world]\ndeparting_vehicle = -1\n")
    lab = tmp_path / "lab.toml"
    lab.write_text("label = 3\n")
    arg = text.format(f=f, missing=tmp_path / "missing.toml", bad=bad, sim=sim, lab=lab)
    with pytest.raises(InputError, match=match) as ei:
        parse_variant_arg(arg)
    assert str(ei.value).startswith("--variant") and "\n" not in str(ei.value)


def test_manifest_form_round_trips_exactly_including_infinity():
    vs = PAPER_VARIANTS + (Variant("axis", "Axis test off", {"landmarks": {"merge_axis_tol_m": math.inf},
                                                              "extent": {"w_mode": "mean", "kappa": 1.5}}),)
    data = variants_to_json(vs)
    assert [d["name"] for d in data] == ["noext", "ext", "axis"]
    assert variants_from_json(data) == vs
    assert math.isinf(tomllib.loads(data[2]["overlay_toml"])["landmarks"]["merge_axis_tol_m"])


def test_overlay_to_toml_nested_tables_and_quoted_keys():
    overlay = {"top": 1, "a": {"x": [1.5, -2.0], "b": {"s": 'q"uote', "weird key": False}}}
    assert tomllib.loads(overlay_to_toml(overlay)) == overlay
