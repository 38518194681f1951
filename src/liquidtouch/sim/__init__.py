"""The physics simulator that stands in for the robot, the bottle and the GelSight sensors."""

from liquidtouch.sim.gelsight import write_sensor_videos
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.presets import simulate_dataset
from liquidtouch.sim.realism import Realism
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial

__all__ = [
    "FingerLoads",
    "Realism",
    "simulate_dataset",
    "simulate_trial",
    "write_sensor_videos",
    "write_trial",
]
