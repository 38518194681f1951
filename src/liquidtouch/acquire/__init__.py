"""Acquisition (the lab path): live GelSight cameras, recording trials, driving the rig.

Grouped by what the parts are (like python-can's interfaces):

- :mod:`~liquidtouch.acquire.cameras`: camera sources -> open cameras and timed frames
  (V4L2, MJPEG over HTTP, RTSP, replayed files), capture threads on one clock;
- :mod:`~liquidtouch.acquire.recording`: cameras -> a lossless trial directory
  (:class:`~liquidtouch.acquire.recording.Recorder`, :func:`~.recording.record`);
- :mod:`~liquidtouch.acquire.grippers`: the gripper (a WSG-50 over its GCL, or a stand-in);
- :mod:`~liquidtouch.acquire.arms`: the arm (a UR arm through ur_rtde, the simulated
  rig's, or a stand-in);
- :mod:`~liquidtouch.acquire.device_link`: device URLs and the line transport the
  gripper and arm clients share;
- :mod:`~liquidtouch.acquire.protocol` (with :mod:`~.protocol_params`): one
  push-and-hold trial on the robot, driving all of the above.

The wire protocols the clients speak are in :mod:`liquidtouch.protocols`, shared
with the simulated rig's servers. Layer 5 (``docs/architecture.md``).
"""
