"""The fused engine under the partial view (docs/method.md a.12; radarslam.slam.fused.view) against
its steps form run event by event (the filter object, EkfSlam with filter.fused false): the same associations, landmark ids, poses, maps and shapes
(the partial-view estimator's in the map's ``rma`` slot, the RMA beneath it in ``efa``) to 1e-9 on
simulated car-park trials under the visible-faces spread model, with each associator the partial
view has, with and without the view-init correction and the shape's uncertainty, with the view
walk, with the ablation shapes, with the shape's Jacobians by central differences (a.12.9), and with
the odometry-bias states between the pose and the landmarks (c.11)."""

from __future__ import annotations

import pytest

from radarslam.core.errors import InputError

from conftest import require
from test_fused import _assert_same_run, _overlay, _scenario

require("numba")

from radarslam.config import profile_config  # noqa: E402
from radarslam.config.variants import CONSISTENT, apply_variant  # noqa: E402
from radarslam.slam import _fused  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402

#: The partial view on the consistent variant (as benchmarks/bench_components.py's row).
VIEW = {"radar": {"spread_model": "visible-faces"}, "extent": {"spread_model": "visible-faces"}}


def _config(overlay: dict):
    cfg = _overlay(apply_variant(profile_config("apsipa"), CONSISTENT), VIEW)
    return _overlay(cfg, overlay)


CASES = {
    "batch-joint": {},
    "batch": {"landmarks": {"associator": "batch"}},
    "nearest-neighbour": {"landmarks": {"associator": "nearest-neighbour"}},
    "no-init-correction": {"extent": {"view_init_correct": False}},
    "no-shape-uncertainty": {"landmarks": {"associator": "batch"}, "extent": {"view_shape_uncertainty": False}},
    "nn-plain": {"landmarks": {"associator": "nearest-neighbour"},
                 "extent": {"view_init_correct": False, "view_shape_uncertainty": False}},
    "view-walk": {"extent": {"view_walk_m2_per_rad": 0.02}},
    "rma-shape-spread-data": {"extent": {"view_shape": "rma", "view_shape_data": "spread"}},
    "prior-shape-radius-sifting": {"extent": {"view_shape": "prior", "contour_sifting": False}},
    "point-init": {"landmarks": {"init": "nearest"}, "extent": {"pre_init_spread": "none"}},
    "central-difference-jacobians": {"extent": {"view_jacobian": "central-difference"}},
    # the landmarks after a platform block of 5 (c.11): every row the partial view indexes moves by 2
    "bias-states": {"filter": {"odometry_bias": "states"}},
    "bias-states-batch": {"landmarks": {"associator": "batch"}, "filter": {"odometry_bias": "states"},
                          "extent": {"view_walk_m2_per_rad": 0.02}},
    "bias-states-nn-central-difference": {"landmarks": {"associator": "nearest-neighbour"},
                                          "filter": {"odometry_bias": "states"},
                                          "extent": {"view_jacobian": "central-difference"}},
}


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("trial", [1, 2])
def test_partial_view_same_as_the_steps_form(name, trial):
    cfg = _config(CASES[name])
    slam = EkfSlam(cfg)
    assert slam.view is not None
    n = _assert_same_run(cfg, _scenario(cfg, trial).events)
    assert n > 500                                    # a real run: hundreds of associations compared


def test_partial_view_estimator_under_the_full_view_is_refused():
    """The partial-view estimator without the partial-view model (its sifting about the arcs'
    means, the full view's association: no step of the engine) is refused in one line when the filter
    is built, as is an associator of the user's own under the partial view."""
    from radarslam.slam.association import NearestNeighbourAssociator

    cfg = _config({"extent": {"estimator": "partial-view", "view_model": "full"}})
    with pytest.raises(InputError, match="extent_estimator: expected the partial-view estimator exactly with "
                                         "extent.view_model partial, got PartialViewEstimator with the full view"):
        EkfSlam(cfg)

    class Mine(NearestNeighbourAssociator):
        pass

    with pytest.raises(InputError, match="associator: expected a built-in associator under the partial view"):
        EkfSlam(_config(CASES[next(iter(CASES))]), associator=Mine(0.0, 1, 1))
