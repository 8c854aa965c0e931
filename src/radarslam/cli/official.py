"""``radarslam run --dataset nuscenes DATAROOT --scene NAME`` and ``--dataset radarscenes DATAROOT
--sequence N``: a dataset in its official layout, read into a recording and run exactly as
``radarslam run --recording`` runs its plain conversion (docs/datasets.md "nuScenes and RadarScenes
in their official layouts")."""

from __future__ import annotations

import argparse

from radarslam.core.errors import InputError

#: The datasets read in their official layout, and the option that names the part to run.
OFFICIAL = {"nuscenes": "--scene", "radarscenes": "--sequence"}
#: Options of ``--dataset victoria-park`` that these runs refuse rather than ignore: (dest, default).
_NOT_HERE = {"--protocol": ("protocol", "aligned"), "--input": ("input", "laser"), "--first-scan": ("first_scan", None),
             "--scans": ("scans", None)}
#: Options of a bag, refused here too.
_BAG = ("--radar-topic", "--odom-topic", "--truth-topic", "--imu-topic", "--doppler-field")


def add_official_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", metavar="NAME", help="--dataset nuscenes: the scene to run, e.g. scene-0061")
    p.add_argument("--version", dest="nuscenes_version", metavar="VERSION",
                   help="--dataset nuscenes: the tables' folder in DATAROOT, e.g. v1.0-mini (default: the one there)")
    p.add_argument("--sequence", metavar="N", help="--dataset radarscenes: the sequence to run, e.g. 105")


def check_official_args(args: argparse.Namespace) -> None:
    """Refuse ``--scene``/``--version`` without ``--dataset nuscenes`` and ``--sequence`` without
    ``--dataset radarscenes``."""
    name = args.dataset[0] if getattr(args, "dataset", None) else None
    for opt, dest, owner in (("--scene", "scene", "nuscenes"), ("--version", "nuscenes_version", "nuscenes"),
                             ("--sequence", "sequence", "radarscenes")):
        if getattr(args, dest, None) is not None and name != owner:
            raise InputError(f"{opt}: expected with --dataset {owner} DATAROOT, got "
                             + (f"--dataset {name}" if name else "no --dataset"))


def official_run_args(args: argparse.Namespace) -> argparse.Namespace:
    """``args`` of ``radarslam run --dataset nuscenes|radarscenes DATAROOT ...`` checked and turned
    into those of the recording run (``cli/recording.py: run_recording_cmd``), which reads the
    dataset with :func:`read_official`."""
    name, path = args.dataset
    if args.recording:
        raise InputError("--recording: expected either --recording or --dataset, got both")
    option = OFFICIAL[name]
    if getattr(args, option[2:]) is None:
        raise InputError(f"{option}: expected with --dataset {name} (e.g. "
                         f"{'--scene scene-0061' if name == 'nuscenes' else '--sequence 105'}), got none")
    for opt, (dest, default) in _NOT_HERE.items():
        if getattr(args, dest, default) != default:
            raise InputError(f"{opt}: defined for --dataset victoria-park, got --dataset {name}")
    for opt in _BAG:
        if getattr(args, opt[2:].replace("-", "_"), None):
            raise InputError(f"{opt}: defined for a bag (--recording BAG), got --dataset {name}")
    args.official, args.recording, args.dataset = name, path, None
    return args


def read_official(args: argparse.Namespace):
    """The :class:`~radarslam.io.recording.stream.Recording` of ``args.official`` at ``args.recording``."""
    if args.official == "nuscenes":
        from radarslam.io.datasets.nuscenes import read_nuscenes

        return read_nuscenes(args.recording, args.scene, version=args.nuscenes_version)
    from radarslam.io.datasets.radarscenes import read_radarscenes

    return read_radarscenes(args.recording, args.sequence)
