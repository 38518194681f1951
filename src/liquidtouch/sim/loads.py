"""What the sloshing simulator hands to the GelSight renderer: the loads on each finger.

Conventions (the renderer relies on them):

- Finger 0 is the ``left`` sensor, finger 1 the ``right`` sensor; both gels face
  the container along the gripper's closing axis.
- In-plane axes are expressed in a common *world* frame: ``x`` horizontal, along
  the container's length (the slosh direction), ``y`` vertical (up). Each
  sensor's camera sees the world mirrored relative to the other, so the same
  world shear moves the two sensors' markers in opposite image senses; the
  renderer applies that mirroring, not the simulator.
- ``shear_force_n`` is the tangential force the container exerts on each gel,
  including the static share of its weight (along ``-y``).
- ``twist_moment_nmm`` is the moment about each gel's normal at the contact
  centre, positive counter-clockwise seen from the container.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FingerLoads"]


@dataclass(frozen=True)
class FingerLoads:
    """Time series of the loads on the two fingers' gels.

    Attributes
    ----------
    t_s : (n,) float
        Sample times [s], uniform, starting at 0 (the start of the recording).
    shear_force_n : (n, 2, 2) float
        Tangential force on each gel [N]; axes are (sample, finger, (x, y)).
    twist_moment_nmm : (n, 2) float
        Moment about each gel's normal [N·mm]; axes are (sample, finger).
    normal_force_n : (2,) float
        Grasp preload on each gel [N] (sets the contact imprint's size and depth).
    contact_center_mm : (2, 2) float
        Contact centre on each gel relative to the gel's centre [mm], (finger, (x, y)).
    """

    t_s: np.ndarray
    shear_force_n: np.ndarray
    twist_moment_nmm: np.ndarray
    normal_force_n: np.ndarray
    contact_center_mm: np.ndarray

    def __post_init__(self) -> None:
        n = self.t_s.shape[0]
        if self.t_s.ndim != 1 or n < 2:
            raise ValueError("t_s must be a 1-D array of at least 2 samples")
        if self.shear_force_n.shape != (n, 2, 2):
            raise ValueError(f"shear_force_n must have shape ({n}, 2, 2)")
        if self.twist_moment_nmm.shape != (n, 2):
            raise ValueError(f"twist_moment_nmm must have shape ({n}, 2)")
        if self.normal_force_n.shape != (2,) or self.contact_center_mm.shape != (2, 2):
            raise ValueError("normal_force_n must be (2,) and contact_center_mm (2, 2)")

    @property
    def duration_s(self) -> float:
        """Length of the recording [s]."""
        return float(self.t_s[-1] - self.t_s[0])
