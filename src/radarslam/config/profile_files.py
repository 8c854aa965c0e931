"""The profiles shipped with the package (``src/radarslam/profiles/*.toml``)."""

from __future__ import annotations

from importlib import resources

#: Where the profiles live: one TOML overlay per profile, its comments giving the reasons.
PROFILE_DIR = "profiles"


def list_profiles() -> list[str]:
    """The shipped profiles (``src/radarslam/profiles/*.toml``), sorted."""
    return sorted(p.name[:-5] for p in resources.files("radarslam").joinpath(PROFILE_DIR).iterdir()
                  if p.name.endswith(".toml"))
