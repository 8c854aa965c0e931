"""Keep numba's on-disk cache in step with the package's sources (docs/architecture.md "Backends").

numba keys a cached function by its own file only: a compiled function whose callee lives in
another module (the fused engine calls the associators of ``slam/_numba.py``, which call the
kernels of ``slam/ekf.py``) keeps its old machine code when only the callee's file changes. An
edited kernel would then run in the engine's steps form but not in its compiled loop. So at import the
package stamps the size and modification time of every file with compiled code; when the stamp
changes, the package's cached machine code is deleted (it is rebuilt on first use, ~90 s), with
the markers that say it is there (:mod:`radarslam.compiling.markers`).
Nothing here imports numba or touches its configuration; a ``NUMBA_CACHE_DIR`` of your own is
yours to clear after editing a compiled source.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

#: Files (relative to the package) whose functions numba compiles, directly or as kernels
#: (``core.jit.compile_kernels``); ``tests/test_layering.py`` checks that it is complete.
COMPILED_SOURCES = (
    "core/angles.py", "core/arrays.py", "core/jit.py", "core/small_matrices.py", "slam/ekf.py", "slam/layout.py",
    "slam/_numba.py", "slam/_jcbb_numba.py", "slam/jcbb_search.py", "slam/state_loops.py",
    "slam/fused/storage.py", "slam/fused/tracking.py", "slam/fused/mapping.py", "slam/fused/engine.py",
    "slam/fused/events.py", "slam/fused/extent.py", "slam/fused/gate.py", "slam/gate_kernels.py",
    "landmarks/confirmation.py", "landmarks/merging.py", "landmarks/sifting.py", "landmarks/grouping.py",
    "landmarks/records.py", "extent/sifting.py", "slam/bias.py",
    "extent/_compiled.py", "extent/_sym2.py", "extent/buffering.py", "extent/measurement.py", "extent/random_matrix.py",
    "extent/ellipse_fit.py", "extent/partial_view.py", "extent/view_estimator.py", "landmarks/_compiled.py",
    "metrics/_compiled.py", "simulation/_compiled.py", "models/radar.py", "models/doppler.py",
    "models/ackermann.py", "models/motion.py", "extent/visible_arc.py", "extent/mem_ekf_kernels.py",
    "extent/ellipse.py", "extent/view_kernels.py", "extent/arc_kernels.py", "models/body_velocity.py", "models/_ransac.py", "models/doppler_kernels.py",
    "models/_doppler_compiled.py", "slam/fused/doppler.py", "models/input_bias.py", "slam/fused/bias.py",
    "slam/view_kernels.py", "slam/_view_compiled.py", "slam/fused/view.py", "extent/partial_view_jac.py",
    "extent/rows.py", "slam/sensor_frame.py", "slam/fused/sensor.py", "slam/scan_frame.py", "slam/radar_time.py",
    "slam/radar_yaw.py", "slam/consider.py",
)
ROOT = Path(__file__).resolve().parents[1]
#: The ending of radarslam's own markers of what numba's cache holds (:mod:`radarslam.compiling.markers`),
#: written beside numba's files and deleted with them.
MARKER_SUFFIX = ".ready"
STAMP = ROOT / "__pycache__" / "numba-sources.stamp"


def sources_stamp(root: Path = ROOT) -> str:
    """Digest of the size and modification time of every file in :data:`COMPILED_SOURCES`."""
    h = hashlib.sha1()
    for rel in COMPILED_SOURCES:
        try:
            st = (root / rel).stat()
            h.update(f"{rel}:{st.st_size}:{st.st_mtime_ns};".encode())
        except OSError:
            h.update(f"{rel}:missing;".encode())
    return h.hexdigest()


def cached_files(root: Path = ROOT) -> list[Path]:
    """numba's cache files of the package (index ``.nbi`` and data ``.nbc``)."""
    return [p for pattern in ("*.nbi", "*.nbc") for p in root.rglob(f"__pycache__/{pattern}")]


def marker_files(root: Path = ROOT) -> list[Path]:
    """radarslam's markers of the package's cached code beside numba's files (:data:`MARKER_SUFFIX`)."""
    return list(root.rglob(f"__pycache__/*{MARKER_SUFFIX}"))


def refresh(root: Path = ROOT, stamp_file: Path | None = None) -> bool:
    """Delete the package's cached machine code if a compiled source changed since the stamp was
    written; True when it did. An unwritable install (numba then caches elsewhere) is left alone."""
    stamp_file = stamp_file or root / "__pycache__" / "numba-sources.stamp"
    now = sources_stamp(root)
    try:
        if stamp_file.read_text() == now:
            return False
    except OSError:
        pass
    try:
        for p in cached_files(root) + marker_files(root):
            p.unlink(missing_ok=True)
        stamp_file.parent.mkdir(exist_ok=True)
        stamp_file.write_text(now)
    except OSError:
        return False
    return True
