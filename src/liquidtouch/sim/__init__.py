"""The physics simulator that stands in for the robot, the bottle and the GelSight sensors.

It also gives the liquid and container catalogue it simulates (:func:`get_liquid`,
:func:`get_container`; defined in ``liquidtouch._core``, where the dataset labels read it).
"""

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import get_liquid
from liquidtouch.sim.gelsight import write_sensor_videos
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.presets import simulate_dataset
from liquidtouch.sim.realism import Realism
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial

__all__ = [
    "FingerLoads",
    "Realism",
    "get_container",
    "get_liquid",
    "simulate_dataset",
    "simulate_trial",
    "write_sensor_videos",
    "write_trial",
]
