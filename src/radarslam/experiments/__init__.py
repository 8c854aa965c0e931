"""Deprecated: the old grab-bag package, split by role (docs/architecture.md "Packages").

``import radarslam.experiments.X`` still works for every module it held and gives the module that
holds it now, with a :class:`DeprecationWarning` naming the new place. ``single`` became two
modules: its event driver is :mod:`radarslam.slam.driver` and its simulated trial
:mod:`radarslam.simulation.trial`; the old name gives the trial module, which also holds
``run_filter`` and ``FilterRecord`` (imported from the driver).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module (under ``radarslam.experiments``) -> the module that holds it now.
MOVED = {
    "single": "radarslam.simulation.trial",
    "recording": "radarslam.runs.recording",
    "recording_outputs": "radarslam.runs.recording_outputs",
    "dataset": "radarslam.runs.dataset",
    "detection_flags": "radarslam.runs.detection_flags",
    "radar_alone": "radarslam.runs.radar_alone",
    "radar_alone_report": "radarslam.runs.radar_alone_report",
    "montecarlo": "radarslam.montecarlo.trials",
    "store": "radarslam.montecarlo.store",
    "report": "radarslam.montecarlo.report",
    "partial_view_study": "radarslam.montecarlo.partial_view_study",
    "variants": "radarslam.config.variants",
    "ego_motion": "radarslam.egomotion.single_radar",
    "rig_velocity": "radarslam.egomotion.rig",
    "rig_odometry": "radarslam.egomotion.rig_odometry",
    "calibrate": "radarslam.egomotion.calibrate",
    "warmup": "radarslam.compiling.warmup",
    "background": "radarslam.compiling.background",
    "first_run": "radarslam.compiling.first_run",
    "dataset_first_run": "radarslam.compiling.stream_plan",
}


def _warn(old: str, new: str) -> None:
    warnings.warn(f"radarslam.experiments.{old} moved to {new}; import it from there", DeprecationWarning,
                  stacklevel=3)


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``radarslam.experiments.<old>`` and hands over the module it moved to."""

    def __init__(self):
        self._specs: dict = {}

    def find_spec(self, fullname, path=None, target=None):
        prefix = __name__ + "."
        if fullname.startswith(prefix) and fullname[len(prefix):] in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        old = spec.name.rsplit(".", 1)[1]
        _warn(old, MOVED[old])
        module = importlib.import_module(MOVED[old])
        self._specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module):
        """The module already ran under its new name; importlib set the alias's spec on it: put its own back."""
        module.__spec__ = self._specs.pop(module.__spec__.name, module.__spec__)


if not any(isinstance(f, _Alias) for f in sys.meta_path):
    sys.meta_path.insert(0, _Alias())


def __getattr__(name: str):
    if name in MOVED:
        _warn(name, MOVED[name])
        module = globals()[name] = importlib.import_module(MOVED[name])
        return module
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
