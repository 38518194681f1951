"""The physics simulator that stands in for the robot, the bottle and the GelSight sensors."""
