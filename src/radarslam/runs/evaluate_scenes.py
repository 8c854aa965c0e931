"""The scenes of ``radarslam evaluate``: recordings, nuScenes scenes, RadarScenes sequences, each
named and given the ``radarslam run`` arguments that read it (docs/datasets.md "A whole dataset:
radarslam evaluate")."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from radarslam.core.errors import DataError, InputError

#: What a scene's name may hold (it names its folder): letters, digits, ``.``, ``_``, ``-``.
_NAME = re.compile(r"[A-Za-z0-9._-]+")


@dataclass(frozen=True)
class Scene:
    """One scene: its ``name`` (its folder in the evaluation) and the ``radarslam run`` arguments
    that read it (``--recording PATH``, ``--dataset nuscenes DATAROOT --scene NAME``, ...)."""

    name: str
    run_args: tuple[str, ...]


def _checked_name(name: str, what: str) -> str:
    if not _NAME.fullmatch(name) or name in (".", ".."):
        raise InputError(f"{what}: expected a scene name of letters, digits, '.', '_' and '-', got {name!r}")
    return name


def recording_scenes(paths: Sequence[str]) -> list[Scene]:
    """A scene per recording (a plain folder or ``.npz``, a bag), named by its file or folder name
    (an ``.npz`` or ``.bag`` without its suffix); two recordings of one name are refused."""
    scenes, seen = [], {}
    for p in paths:
        path = Path(p)
        if not path.exists():
            raise InputError(f"--recordings: {p}: no such file or directory")
        name = path.resolve().name
        if path.is_file() and path.suffix in (".npz", ".bag"):
            name = path.stem
        name = _checked_name(name, "--recordings")
        if name in seen:
            raise InputError(f"--recordings: two recordings named {name!r} ({seen[name]} and {p}); each scene's "
                             "folder is its recording's name")
        seen[name] = p
        scenes.append(Scene(name, ("--recording", str(p))))
    return scenes


def nuscenes_scenes(dataroot: str, names: Sequence[str], version: str | None = None) -> list[Scene]:
    """The named scenes of the nuScenes dataset at ``dataroot`` (``["all"]``: every scene of
    ``scene.json`` whose CAN bus wheel speeds and IMU files exist), each checked against scene.json."""
    from radarslam.io.datasets.nuscenes import can_bus, tables as T

    root = Path(dataroot)
    if not root.is_dir():
        raise InputError(f"--dataset nuscenes: expected the nuScenes folder (holding v1.0-*/ and can_bus/), got "
                         f"{dataroot}: no such directory")
    folder = T.version_folder(root, version)
    known = [str(s.get("name")) for s in T.load_table(folder, "scene")]
    extra = ("--version", version) if version else ()
    if list(names) == ["all"]:
        can = root / "can_bus"
        chosen = [n for n in known if all(can_bus.can_file(can, n, m).is_file() for m in ("zoe_veh_info", "ms_imu"))]
        if not chosen:
            raise DataError(f"{can}: expected the CAN bus files (<scene>_zoe_veh_info.json, <scene>_ms_imu.json) of "
                            f"at least one of the {len(known)} scenes of {folder / 'scene.json'}, got none")
    else:
        for n in names:
            if n not in known:
                shown = ", ".join(sorted(known)[:40]) + (f", ... ({len(known)} scenes)" if len(known) > 40 else "")
                raise InputError(f"--scenes: expected scenes of {folder / 'scene.json'} ({shown}), got {n!r}")
        chosen = list(dict.fromkeys(names))
    return [Scene(_checked_name(n, "--scenes"), ("--dataset", "nuscenes", str(dataroot), "--scene", n, *extra))
            for n in chosen]


def radarscenes_scenes(dataroot: str, names: Sequence[str]) -> list[Scene]:
    """The named sequences (numbers, or ``sequence_N``) of the RadarScenes dataset at ``dataroot``
    (``["all"]``: every ``data/sequence_*`` folder, by number), each named ``sequence_N``."""
    from radarslam.io.datasets.radarscenes import sequence_folder

    root = Path(dataroot)
    if list(names) == ["all"]:
        if not root.is_dir():
            raise InputError(f"--dataset radarscenes: expected the RadarScenes folder (holding data/sequence_N/), "
                             f"got {dataroot}: no such directory")
        data = root / "data" if (root / "data").is_dir() else root
        found = [p.name for p in data.glob("sequence_*") if p.is_dir() and p.name[len("sequence_"):].isdigit()]
        if not found:
            raise InputError(f"--dataset radarscenes: expected sequence_N folders in {data}, got none")
        numbers = sorted(found, key=lambda s: int(s[len("sequence_"):]))
    else:
        numbers = []
        for n in names:
            try:
                folder, _ = sequence_folder(root, n)
            except InputError as exc:
                raise InputError(str(exc).replace("--sequence:", "--scenes:", 1)) from None
            numbers.append(folder.name)
        numbers = list(dict.fromkeys(numbers))
    return [Scene(n, ("--dataset", "radarscenes", str(dataroot), "--sequence", n[len("sequence_"):]))
            for n in numbers]


def dataset_scenes(name: str, dataroot: str, scenes: Sequence[str], version: str | None = None) -> list[Scene]:
    """The scenes of ``--dataset NAME DATAROOT --scenes ...``."""
    if name == "nuscenes":
        return nuscenes_scenes(dataroot, scenes, version)
    if version is not None:
        raise InputError(f"--version: expected with --dataset nuscenes, got --dataset {name}")
    if name == "radarscenes":
        return radarscenes_scenes(dataroot, scenes)
    raise InputError(f"--dataset: expected nuscenes or radarscenes, got {name!r}")
