"""The configuration's tables of data: the paper's car park, the size limits of a run and the
spread factors of the radar's spread models (docs/method.md a.11, b.1), read by the sections
(:mod:`radarslam.config.sections`, which re-exports them) and by the loader."""

from __future__ import annotations

#: The 12 vehicles of the car park as [x_left, y_bottom, size_x, size_y] (docs/method.md b.1, HEAD layout).
CARPARK_VEHICLES = [
    [30.0, 0.0, 4.0, 2.0], [30.0, 15.0, 4.0, 2.0],                       # G1
    [5.0, 5.0, 4.0, 2.0], [5.0, 10.0, 4.0, 2.0], [5.0, 15.0, 4.0, 2.0],  # G2
    [-14.0, 4.0, 2.0, 4.0], [-14.0, 12.0, 2.0, 4.0], [-14.0, 18.0, 2.0, 4.0],  # G3
    [2.0, -8.0, 5.0, 2.0], [11.0, -8.0, 5.0, 2.0],                       # G4
    [4.0, 33.0, 5.0, 2.0], [14.0, 33.0, 5.0, 2.0],                       # G5
]


#: Size limits that keep a run within memory (checked up front, the limit in the message).
MAX_STEPS = 100_000
#: Expected detections of one scan (vehicles and clutter) a simulation may draw.
MAX_DETECTIONS_PER_SCAN = 100_000
#: The spread factor gamma_z of each spread model (docs/method.md a.11): the detection scatter about
#: the centroid is gamma_z X for an object whose extent is X. Uniform over an ellipse's surface:
#: 1/4 (d.4); on its outline: 1/2; on the faces in view (points on the outline): 1/2; scatter-centres:
#: 0.6, measured on the simulated car parks (b.4.2, scripts/scatter_centres_stats.py).
SPREAD_FACTORS = {"surface": 0.25, "contour": 0.5, "visible-faces": 0.5, "scatter-centres": 0.6}
#: Spread models whose detections come from the part of a car in view (a.12): extent.view_model
#: "auto" takes the partial-view model for these.
PARTIAL_VIEW_SPREAD_MODELS = ("visible-faces", "scatter-centres")

#: Most vehicles a generated car park may hold (world.layout = "rows").
MAX_VEHICLES = 100_000
