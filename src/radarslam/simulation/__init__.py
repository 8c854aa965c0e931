"""The simulated car park of the APSIPA 2022 and seed papers (docs/method.md section b)."""

from radarslam.simulation.scenario import GroundTruth, Scenario, generate_scenario
from radarslam.simulation.world import Vehicle, carpark_vehicles

__all__ = ["GroundTruth", "Scenario", "Vehicle", "carpark_vehicles", "generate_scenario"]
