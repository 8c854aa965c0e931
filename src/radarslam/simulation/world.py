"""Vehicles of the car park as axis-aligned rectangles (docs/method.md b.1)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from radarslam.config import WorldConfig


@dataclass(frozen=True)
class Vehicle:
    """An axis-aligned rectangle ``[x_left, y_bottom, size_x, size_y]`` present for ``k < departure``."""

    index: int
    x_left: float
    y_bottom: float
    size_x: float
    size_y: float
    departure: int | None = None

    @property
    def center(self) -> np.ndarray:
        """Rectangle centre (2,)."""
        return np.array([self.x_left + 0.5 * self.size_x, self.y_bottom + 0.5 * self.size_y])

    @functools.cached_property
    def size(self) -> np.ndarray:
        """``[size_x, size_y]`` (2,), read-only (kept: the simulator scales every scan's draws by it)."""
        return _frozen([self.size_x, self.size_y])

    @functools.cached_property
    def corner(self) -> np.ndarray:
        """``[x_left, y_bottom]`` (2,), read-only."""
        return _frozen([self.x_left, self.y_bottom])

    @property
    def length(self) -> float:
        """Long side L (m)."""
        return max(self.size_x, self.size_y)

    @property
    def width(self) -> float:
        """Short side W (m)."""
        return min(self.size_x, self.size_y)

    @property
    def orientation(self) -> float:
        """Orientation of the long axis: 0 along x, pi/2 along y."""
        return 0.0 if self.size_x >= self.size_y else 0.5 * math.pi

    @property
    def area(self) -> float:
        return self.size_x * self.size_y

    def present(self, k: int) -> bool:
        """Whether the vehicle is in the scene at step ``k`` (Decision 2)."""
        return self.departure is None or k < self.departure


def _frozen(values) -> np.ndarray:
    a = np.array(values, dtype=float)
    a.flags.writeable = False
    return a


def row_geometry(world: WorldConfig) -> tuple[float, float, float]:
    """``(pitch, row_length, straight)`` of the generated car park (docs/method.md b.1.1): the
    distance between neighbouring aisles, the length of a row of cars and the straight drive along
    an aisle (the row plus a margin at each end), in metres."""
    pitch = 2.0 * world.car_length_m + world.aisle_width_m + world.row_back_gap_m
    row_length = world.cars_per_row * world.car_width_m + (world.cars_per_row - 1) * world.car_gap_m
    return pitch, row_length, row_length + 2.0 * world.row_margin_m


def rows_layout(world: WorldConfig) -> list[list[float]]:
    """Rectangles ``[x_left, y_bottom, size_x, size_y]`` of the generated car park (b.1.1).

    Aisle ``a`` runs along x at ``y = a * pitch`` from ``x = 0``; row ``i`` lies below aisle
    ``i // 2`` (even ``i``) or above it (odd ``i``), its cars parked across the row (``size_y`` is
    the car's length) from ``x = row_margin`` on, ``car_gap`` apart. Rows ``2a + 1`` and ``2a + 2``
    stand back to back between aisles ``a`` and ``a + 1``, ``row_back_gap`` apart.
    """
    pitch, _, _ = row_geometry(world)
    L, W, half = world.car_length_m, world.car_width_m, 0.5 * world.aisle_width_m
    out = []
    for i in range(world.rows):
        y_aisle = (i // 2) * pitch
        y_bottom = y_aisle - half - L if i % 2 == 0 else y_aisle + half
        for c in range(world.cars_per_row):
            out.append([world.row_margin_m + c * (W + world.car_gap_m), y_bottom, W, L])
    return out


def carpark_vehicles(world: WorldConfig) -> list[Vehicle]:
    """The vehicles of ``world`` (its list, or the generated rows of b.1.1) with the departure applied."""
    out = []
    rects = rows_layout(world) if world.layout == "rows" else world.vehicles
    for i, (x, y, sx, sy) in enumerate(rects):
        dep = world.departure_step if i == world.departing_vehicle else None
        out.append(Vehicle(i, float(x), float(y), float(sx), float(sy), dep))
    return out


def presence(vehicles: list[Vehicle], n_steps: int) -> np.ndarray:
    """``(K, V)`` boolean: vehicle present at step k = 1..K (row k - 1)."""
    ks = np.arange(1, n_steps + 1)[:, None]
    dep = np.array([np.inf if v.departure is None else v.departure for v in vehicles])[None, :]
    return ks < dep
