"""The filter over a recorded stream, for every run of one (docs/architecture.md "The path of a
recording"): a recording's (:func:`radarslam.runs.recording.run_recording`), the radar alone's and a
dataset's (:func:`radarslam.runs.dataset.run_dataset`) all run their events through
:func:`run_stream` and give the one run type, :class:`~radarslam.runs.recording.RecordingRun`, whose
record :class:`RecordViews` reads by the names of the estimate."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from radarslam.config import Config
from radarslam.core.errors import ConfigError
from radarslam.slam.driver import FilterRecord, Observer, drive


def refuse_drawn_start(config: Config) -> None:
    """Refuse in one line a start drawn about the true first pose (b.5), which real data has not."""
    if config.filter.initial_error != "fixed":
        raise ConfigError(f"filter.initial_error: expected 'fixed' for real data (no true first pose to draw about), "
                          f"got {config.filter.initial_error!r}")


def refuse_online_car_states(config: Config) -> None:
    """Refuse in one line a recording run with the car's online states (the thrust angle, each radar's
    yaw and time offset, docs/method.md c.13.3) under ``filter.online_car_states = "refuse"`` (the
    ``automotive`` profile's: on every given nuScenes scene they make the run worse than the profile
    without them, with the radars calibrated from another drive too)."""
    f = config.filter
    on = [k for k in ("bias_thrust", "radar_yaw_states", "radar_time_states") if getattr(f, k)]
    if f.online_car_states == "refuse" and f.odometry_bias == "states" and on and f.car_states == "estimate":
        raise ConfigError(f"filter.{', filter.'.join(on)}: refused under profile 'automotive': on the four given "
                          "nuScenes scenes the car's online states make every run worse than the profile without them "
                          "(scene-0061 0.47 -> 2.06 m; the landmarks teach them wrong values, docs/method.md c.13.3); "
                          "filter.car_states = 'consider' carries them in the covariance without learning them, "
                          "filter.online_car_states = 'allow' runs them anyway")


def run_stream(config: Config, events: list, first_run=None, *, observers: Sequence[Observer] = (),
               maps: str = "all", on_scan=None, heartbeat: bool = True, on_scans=None) -> FilterRecord:
    """The filter over ``events`` (:func:`~radarslam.slam.driver.drive`, told to ``observers``) by
    the first-run plan's engine (``first_run``, a :class:`~radarslam.compiling.policy.Plan`; None:
    the configuration's): the compiled engine, its steps form or its Python form. A plan that compiles
    the steps form's kernels first says, with ``heartbeat``, every few seconds that it is still
    compiling; a plan that took the Python form for a compiled configuration records the engine
    ``"python"``. ``maps="last"`` keeps the map after the last scan only (a long recording).
    ``on_scan()`` and ``on_scans(n)``: :func:`~radarslam.slam.driver.drive`'s."""
    from radarslam.compiling.heartbeat import _heartbeat

    engine = "auto" if first_run is None else first_run.engine
    compiles = first_run is not None and first_run.compiles and engine == "steps"
    with _heartbeat(first_run.compile_s if compiles and heartbeat else 0.0) as compiled:
        n = [0]

        def tick():                      # numba compiles the steps' kernels within the first scans
            if on_scan is not None:
                on_scan()
            n[0] += 1
            if n[0] == 2:
                compiled.set()
        # the plan's Python form is the reference backend's whole (its numpy EKF updates and the Doppler
        # gate's reference, slam/fused/own.py reference_kernels): a first run compiles nothing
        run_config = config if engine != "python" else dataclasses.replace(
            config, filter=dataclasses.replace(config.filter, backend="python"))
        record = drive(run_config, events, engine={"python": "fused-python", "steps": "fused-steps"}.get(engine, "auto"),
                       observers=observers, maps=maps, on_scan=tick, on_scans=on_scans)
    if engine == "python" and config.filter.backend != "python":   # the plan chose the reference (a first run)
        record.engine = "python"
    return record


class RecordViews:
    """What a run estimated, read from its :class:`~radarslam.slam.driver.FilterRecord` (``record``)
    by name: the pose after every scan, the final map, every NIS, the bias states."""

    record: FilterRecord
    recording: object

    @property
    def poses(self) -> np.ndarray:
        """(K, 3): the pose after every scan."""
        return self.record.poses

    @property
    def pose_covs(self) -> np.ndarray:
        """(K, 3, 3): its covariance."""
        return self.record.pose_covs

    @property
    def n_landmarks(self) -> np.ndarray:
        """(K,): the landmarks in the state after every scan."""
        return self.record.n_landmarks

    @property
    def n_associated(self) -> np.ndarray:
        """(K,): the detections associated at every scan."""
        return self.record.n_associated

    @property
    def final_map(self):
        """The :class:`~radarslam.slam.filter.MapSnapshot` after the last scan."""
        return self.record.maps[-1]

    @property
    def nis(self) -> np.ndarray:
        """(u, 2): every association update's scan position and NIS (2 dof)."""
        return self.record.nis_rows

    @property
    def seconds(self) -> float:
        """Wall time of the filter (s)."""
        return self.record.seconds

    @property
    def engine(self) -> str:
        """What ran the filter: ``"fused"``, ``"fused-steps"``, ``"fused-python"``, or ``"python"`` (a first run's Python form)."""
        return self.record.engine

    @property
    def bias_names(self) -> tuple[str, ...]:
        """The odometry-bias states' names (docs/method.md c.11); empty without them."""
        return self.record.bias_names

    @property
    def bias_units(self) -> tuple[str, ...]:
        """Their units."""
        return self.record.bias_units

    @property
    def bias(self) -> np.ndarray | None:
        """(K, m): the bias states after every scan; None without them."""
        b = self.record.bias
        return None if b is None else b[:, :len(self.record.bias_names)]

    @property
    def bias_std(self) -> np.ndarray | None:
        """(K, m): their standard deviations; None without them."""
        b = self.record.bias
        return None if b is None else b[:, len(self.record.bias_names):]

    @property
    def data(self):
        """The input the run read (``recording``): a recording, or a dataset's loaded data."""
        return self.recording
