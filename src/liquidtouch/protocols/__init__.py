"""The wire protocols, each written once and shared by its client and its server.

- :mod:`~liquidtouch.protocols.gcl`: the Weiss WSG-50's text command interface (GCL):
  commands, replies, error codes, grasping states, limits, port. Client:
  :mod:`liquidtouch.acquire.grippers`; server: :mod:`liquidtouch.sim.rig.gcl_server`.
- :mod:`~liquidtouch.protocols.arm`: the simulated rig's arm protocol (JSON lines):
  version, greeting, commands, replies. Client: :mod:`liquidtouch.acquire.arms`;
  server: :mod:`liquidtouch.sim.rig.arm_server`.
- :mod:`~liquidtouch.protocols.mjpeg`: MJPEG over HTTP as mjpg-streamer serves it
  (multipart boundary, part headers, ``X-Timestamp``). Client:
  :mod:`liquidtouch.acquire.cameras.mjpeg`; server: :mod:`liquidtouch.sim.rig.mjpeg`.

Layer 2 (``docs/architecture.md``): imports only :mod:`liquidtouch.errors` and
:mod:`liquidtouch._core`, so the lab path (``acquire``) and the simulated rig
(``sim.rig``) both build on it without importing each other. The modules are imported
by their full path (``from liquidtouch.protocols import gcl``).
"""
