"""A simulated lab rig: GelSight cameras streamed like the real ones, gripper and arm stand-ins."""
