"""The one compile policy: what a command runs while numba's cache lacks the machine code it needs
(docs/speed.md "First run"; docs/architecture.md "Compiling and the first run").

Every command asks :func:`plan` with its :class:`Workload` (one simulated trial, a Monte Carlo's
trials, a recorded stream of scans and detections) and gets one :class:`Plan`: the engine that
ends the run soonest by the measured costs of :mod:`.costs` (the fused engine compiled, first if
it must be; its steps form over its compiled kernels, those compiled first if they must be; or its
Python form, at once), which parts go through their reference, whether numba compiles in the
foreground and for how long, whether the compiled engine should compile in the background for the
runs that come after, and the first line that says so. Every form gives the same results (the same
code; tests/test_engine_forms.py).
Readiness is read by :mod:`.readiness`; nothing here compiles or starts a process.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from radarslam.compiling.costs import (FUSED_COMPILE_S, FUSED_SCAN_S, STEPS_COMPILE_S, STEPS_SCAN_S,
                                       PYTHON_DETECTION_SCAN_S, PYTHON_SCAN_S, first_run_engine,
                                       first_run_engine_scans)
from radarslam.compiling.readiness import (_steps_are_cold, cache_is_cold, engines, fused_families,
                                           fused_is_cold, ready)
from radarslam.config import Config
from radarslam.core.errors import ConfigError

#: What the progress output says while the fused engine compiles in the foreground.
COMPILING = "compiling the numba kernels (once per machine, about three minutes); later runs load them in about a second"
#: ``kind`` of a :class:`Workload`.
KINDS = ("trial", "trials", "stream")


@dataclass(frozen=True)
class Workload:
    """What a command is about to run.

    Attributes
    ----------
    kind : str
        ``"trial"``: one simulated trial (``run --seed``); ``"trials"``: a Monte Carlo of
        ``n_trials`` trials of ``len(variants)`` variants on ``jobs`` workers; ``"stream"``: a
        recorded stream of ``n_scans`` scans and ``n_detections`` detections (a recording, a dataset).
    simulation, matching : bool
        A trial also simulates the car park and matches the map to its truth (their own kernels).
    fused : bool
        The configuration asks for the compiled engine (``filter.fused``).
    """

    kind: str
    n_scans: int = 0
    n_detections: int = 0
    n_trials: int = 1
    jobs: int = 1
    variants: tuple = ()
    simulation: bool = False
    matching: bool = False
    fused: bool = True


@dataclass(frozen=True)
class Plan:
    """How a command runs (:func:`plan`).

    Attributes
    ----------
    engine : str
        ``"auto"`` (the configuration's: the fused engine where it covers it, every part ready or
        compiled first), ``"fused"``, ``"steps"`` (the engine's steps form, its kernels compiled) or
        ``"python"`` (its Python form, the reference).
    compiles : bool
        numba compiles in the foreground within this run, for about ``compile_s`` seconds.
    announce : str
        The first line of stderr ("" for none): what runs, why, and how long it is expected to take.
    simulation_compiled, matching_compiled : bool
        Whether a trial's scan simulation and the evaluation's matching run compiled.
    reference_parts : tuple of str
        The parts that run through their reference.
    background : bool
        The fused engine should compile in a detached process for the runs that come after.
    """

    engine: str = "auto"
    compiles: bool = False
    compile_s: float = 0.0
    announce: str = ""
    simulation_compiled: bool = True
    matching_compiled: bool = True
    reference_parts: tuple[str, ...] = ()
    background: bool = False
    expected_s: float = field(default=0.0, compare=False)   # what the plan expects the run to take (s)

    @property
    def filter_backend(self) -> str | None:
        """``"python"`` when the filter runs through its reference, else None (the configuration's)."""
        return "python" if self.engine == "python" else None


def plan(config: Config, workload: Workload) -> Plan:
    """The plan of ``workload`` under ``config`` on this machine now (module docstring)."""
    if workload.kind not in KINDS:
        raise ConfigError(f"workload.kind: expected one of {', '.join(KINDS)}, got {workload.kind!r}")
    if config.filter.backend != "numba":       # the reference everywhere already: nothing to decide or say
        return {"stream": Plan("python"), "trial": Plan(simulation_compiled=False, matching_compiled=False)}.get(
            workload.kind, Plan())
    return {"trial": _trial, "trials": _trials, "stream": _stream}[workload.kind](config, workload)


# --- one simulated trial: each part compiled when its code is ready, else its reference -----------

def _filter_ready(*families) -> bool:
    """True when the fused engine of each of ``families`` is ready (none given: the default family's)."""
    return all(ready(d) for d in engines(families))


def _simulation_ready() -> bool:
    from radarslam.simulation._compiled import simulate_scans

    return ready(simulate_scans)


def _matching_ready() -> bool:
    from radarslam.metrics._compiled import match_scans

    return ready(match_scans)


def _trial(config: Config, w: Workload) -> Plan:
    """A trial takes about a second through the reference, far less than any compile: each part
    runs compiled only when its machine code is ready; the rest compiles in the background."""
    parts = []
    f = _filter_ready(*fused_families(config))
    if not f:
        parts.append("filter")
    s = not w.simulation or _simulation_ready()
    if not s:
        parts.append("simulation")
    m = not w.matching or _matching_ready()
    if not m:
        parts.append("evaluation")
    return Plan("auto" if f else "python", simulation_compiled=s, matching_compiled=m, reference_parts=tuple(parts),
                background=bool(parts))


# --- a Monte Carlo: compile the fused engine first, or run a short one by its steps form ---------

def _trials(config: Config, w: Workload) -> Plan:
    """Warm: nothing to do. Cold: the fused engine compiled first, or (a run short enough to end
    sooner so, :func:`~.costs.first_run_engine`) the kernels of its steps form, or (shorter still,
    the steps' kernels not compiled) the Python reference whole at once; the fused engine then
    compiling in the background."""
    families = fused_families(config, w.variants)
    if not cache_is_cold(*families):
        return Plan()
    short = first_run_engine(w.n_trials, max(1, len(w.variants)), w.jobs) if (
        w.n_trials > 0 and fused_is_cold(*families)) else "auto"
    if short == "python" and _steps_are_cold():
        return Plan("python", background=True, simulation_compiled=False, matching_compiled=False,
                    reference_parts=("filter", "simulation", "evaluation"))
    if short != "auto":
        return Plan("steps", compiles=_steps_are_cold(), background=True)
    return Plan("auto", compiles=True)


# --- a recorded stream: what ends sooner, from its size ------------------------------------------

def _steps_ready() -> bool:
    """True when the kernels the engine's steps form calls are compiled or cached (readiness.py
    ``steps_kernels``)."""
    from radarslam.compiling.readiness import steps_kernels

    return all(ready(d) for d in steps_kernels())


def _gate_ready(config: Config) -> bool:
    """True when the run event by event has nothing more to compile for ``config``'s Doppler gate
    (``filter.doppler_gate``: its per-scan classification, c.10.4; 28 s of compile on its own, which
    a run thought ready would spend without a word); True without the gate."""
    if not config.filter.doppler_gate:
        return True
    from radarslam.models._doppler_compiled import classify_scan

    return ready(classify_scan)


def _fused_ready(*families) -> bool:
    """True when the machine code of the fused engine of ``families`` (none given: the default
    family's) is ready."""
    return _filter_ready(*families)


def python_seconds(n_scans: int, n_detections: int = 0) -> float:
    """The expected seconds of a stream through the Python reference: with its detections known, a
    cost per detection that grows with the map (the association looks at every landmark, and the
    landmarks grow with the drive: :data:`~.costs.PYTHON_DETECTION_SCAN_S`); else per scan
    (:data:`~.costs.PYTHON_SCAN_S`, a dataset's scans with their detections)."""
    if n_detections:
        return n_detections * n_scans * PYTHON_DETECTION_SCAN_S
    return n_scans * PYTHON_SCAN_S


def _stream(config: Config, w: Workload) -> Plan:
    """The compiled engine (``filter.fused``) when its machine code is ready, or when a stream this long
    ends sooner compiling it (:func:`~.costs.first_run_engine_scans`); else the engine's steps form when
    its kernels are ready, else what ends sooner, the Python form at once (:func:`python_seconds`) or
    the steps form after numba compiles its kernels. The compiled engine then compiles in the background
    for later runs (``background``)."""
    n = w.n_scans
    if w.fused and _fused_ready(*fused_families(config)):
        return Plan("fused", expected_s=n * FUSED_SCAN_S)     # its progress moves part by part (fused/chunks.py)
    if w.fused and first_run_engine_scans(n) == "auto":
        return Plan("fused", compiles=True, announce=COMPILING, expected_s=FUSED_COMPILE_S + n * FUSED_SCAN_S)
    if _steps_ready() and _gate_ready(config):
        return Plan("steps", background=w.fused, expected_s=n * STEPS_SCAN_S, announce=(
            f"the fused engine is not compiled on this machine yet and {n} scans end sooner without it: this run goes "
            "through the engine's steps form (the same results)") if w.fused else "")
    python_s = python_seconds(n, w.n_detections)
    run_s = n * STEPS_SCAN_S
    if python_s <= STEPS_COMPILE_S + run_s:
        return Plan("python", background=w.fused, reference_parts=("filter",), expected_s=python_s, announce=(
            f"first run on this machine: the compiled code is not built yet, so these {n} scans go through the "
            f"Python reference (about {python_s:.0f} s; compiling first would take about "
            f"{STEPS_COMPILE_S + run_s:.0f} s; the same results)"))
    return Plan("steps", True, STEPS_COMPILE_S, background=w.fused,
                expected_s=STEPS_COMPILE_S + run_s, announce=(
        f"first run on this machine: compiling the kernels of the engine's steps (once per machine, about "
        f"{STEPS_COMPILE_S:.0f} s on two cores), then {n} scans through its steps form (about {run_s:.0f} s; the "
        f"Python reference would take about {python_s:.0f} s; the same results)"))
