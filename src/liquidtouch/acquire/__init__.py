"""Acquisition (the lab path): live GelSight cameras, recording trials, driving the rig."""
