"""``liquidtouch rig serve`` (the simulated robot) and ``liquidtouch run-trial`` (a trial).

``rig serve`` starts the simulated rig of :mod:`liquidtouch.sim.rig.rig`: a WSG-50
gripper speaking its real text protocol, a UR-like arm endpoint and two GelSight
MJPEG streams, all showing one simulated bottle of liquid. It prints the endpoints
(and the liquid's true λ, ω) and runs until Ctrl-C.

``run-trial`` runs the protocol of :mod:`liquidtouch.acquire.protocol` on a gripper,
an arm and the cameras (real ones, or the rig's): grasp, lift, record, push, hold,
lower, release. On any error or Ctrl-C the arm stops, the gripper keeps holding and
no trial directory is left.
"""

from __future__ import annotations

import functools
import json
import math
import signal
import sys
import threading
from pathlib import Path

import typer

from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
    TRIAL_READ_TIMEOUT_S,
)
from liquidtouch.cli import options

rig_app = typer.Typer(
    help="The simulated lab rig: gripper, arm and GelSight cameras on the network.",
    no_args_is_help=True,
)


def register(app: typer.Typer) -> None:
    """Register ``rig`` (a command group) and ``run-trial`` on ``app``."""
    app.add_typer(rig_app, name="rig")
    app.command("run-trial")(run_trial_command)


@rig_app.command("serve")
def serve_command(
    liquid: str = typer.Option(
        ..., "--liquid", help="water, olive-oil, corn-oil, mirin, detergent or sugar-water."
    ),
    height_mm: float = typer.Option(..., "--height-mm", help="Fill height [mm]."),
    container: str = typer.Option(
        "grooved-cuboid", "--container", help="grooved-cuboid, cuboid, cylinder or glass."
    ),
    sugar_concentration: float | None = typer.Option(
        None, "--sugar-concentration", help="Sugar-water only: g sugar per 100 g water."
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed of the simulated conditions."),
    sensor: str = typer.Option(
        "default", "--sensor", help="GelSight profile: default (640x480, 30 fps) or mini."
    ),
    gel: options.Gel = None,
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to listen on (default: this machine only)."
    ),
    gripper_port: int = typer.Option(
        0, "--gripper-port", help="TCP port of the gripper (GCL); 0: any free port."
    ),
    arm_port: int = typer.Option(0, "--arm-port", help="TCP port of the arm; 0: any free port."),
    camera_port: int = typer.Option(
        0,
        "--camera-port",
        help="HTTP port of the left camera's stream, the right one's is the next; "
        "0: any free ports.",
    ),
    as_json: bool = typer.Option(
        False, "--json", help="Print one JSON object (endpoints and truth) on stdout."
    ),
) -> None:
    """Serve a simulated rig until Ctrl-C: print the gripper, arm and camera URLs.

    The gripper is a WSG-50 on its text interface (wsg50://HOST:PORT), the arm a
    UR-like endpoint (sim://HOST:PORT), the two GelSight sensors MJPEG streams
    (http://HOST:PORT/stream). A push of the lifted bottle runs the simulator with
    that push; the liquid's true decay rate and angular frequency are printed (and
    answered by the arm's "truth" request). Give these URLs to run-trial.
    """
    from liquidtouch.errors import LiquidTouchError
    from liquidtouch.sim.rig.rig import RigServer
    from liquidtouch.sim.rig.state import Rig
    from liquidtouch.sim.sensors import with_gel

    for name, port in (
        ("--gripper-port", gripper_port),
        ("--arm-port", arm_port),
        ("--camera-port", camera_port),
    ):
        if not 0 <= port <= (65534 if name == "--camera-port" else 65535):
            raise LiquidTouchError(f"{name} {port} is not a TCP port (0-65535)")
    rig = Rig(
        liquid,
        height_mm=height_mm,
        container=container,
        sugar_concentration=sugar_concentration,
        seed=seed,
        sensor=with_gel(sensor, gel and gel.value),
    )
    cameras = (camera_port, camera_port + 1 if camera_port else 0)
    stop = threading.Event()
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    except ValueError:  # not the main thread (e.g. called from a test's thread)
        previous = None
    server = RigServer(
        rig, host=host, gripper_port=gripper_port, arm_port=arm_port, camera_ports=cameras
    )
    try:
        try:
            server.start()
        except OSError as exc:
            raise LiquidTouchError(f"cannot listen on {host}: {exc.strerror or exc}") from None
        endpoints = server.endpoints()
        if as_json:
            typer.echo(json.dumps(endpoints))
        else:
            truth = endpoints["truth"]
            typer.echo(f"gripper  {endpoints['gripper']}")
            typer.echo(f"arm      {endpoints['arm']}")
            for name, url in endpoints["cameras"].items():
                typer.echo(f"camera   {url}  ({name})")
            typer.echo(
                f"truth    λ = {truth['true_decay_rate']:.5f} 1/s, "
                f"ω = {truth['true_angular_frequency']:.4f} rad/s "
                f"({truth['liquid']}, {truth['height_mm']:g} mm, {truth['container']}, "
                f"seed {truth['seed']})"
            )
            typer.echo("serving; Ctrl-C stops")
        sys.stdout.flush()
        try:
            while not stop.wait(0.5):
                for stream in server.streams:
                    if stream.error is not None:
                        raise LiquidTouchError(f"a camera stream failed: {stream.error}")
        except KeyboardInterrupt:
            pass
    finally:
        server.stop()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def run_trial_command(
    gripper: str = typer.Option(
        ..., "--gripper", help="Gripper URL: wsg50://HOST[:PORT] (a WSG-50; port 1000) or sim://."
    ),
    arm: str = typer.Option(
        ...,
        "--arm",
        help="Arm URL: ur-rtde://HOST (a UR arm, needs liquidtouch[robot]), sim://HOST:PORT "
        "(the simulated rig) or sim://.",
    ),
    camera: list[str] = typer.Option(
        ...,
        "--camera",
        help="A camera source, repeated (left first): a device index, /dev/videoN, "
        "name:GelSight Mini, an http/rtsp stream URL.",
    ),
    out: Path = typer.Option(
        ..., "--out", "-o", file_okay=False, help="Trial directory to create (new or empty)."
    ),
    protocol: Path | None = typer.Option(
        None,
        "--protocol",
        dir_okay=False,
        help="Protocol TOML file (grasp force, lift, push, hold, ...); default: the paper's.",
    ),
    label: options.Labels = [],  # noqa: B006 - typer reads the default, never mutates it
    name: list[str] = typer.Option(
        [],
        "--name",
        help="Sensor names, one per camera, in order (default left, right).",
        show_default=False,
    ),
    seconds: float | None = typer.Option(
        None, "--seconds", help="Recording after the push [s] (the protocol's hold_s)."
    ),
    as_json: bool = typer.Option(
        False, "--json", help="Print one JSON object on stdout (trial, push times, summary)."
    ),
    model_file: Path | None = typer.Option(
        None,
        "--model",
        help="Estimate live from the frames being recorded (the push and the end of the hold "
        "from the protocol), with this model file; writes live.json into the trial.",
        show_default=False,
    ),
    live: bool = typer.Option(
        False, "--live", help="Estimate live (as --model, without a model).", show_default=False
    ),
    serve: str | None = typer.Option(
        None,
        "--serve",
        metavar="HOST:PORT",
        help="Show the live estimate in a browser at http://HOST:PORT (implies --live).",
        show_default=False,
    ),
    until_std: list[str] = typer.Option(
        [],
        "--until-std",
        metavar="TARGET=STD",
        help="Live: the estimate is final once every TARGET's std is below STD.",
        show_default=False,
    ),
    sensor: options.SensorChoice | None = typer.Option(
        None,
        "--sensor",
        help="Sensor profile of the cameras (as record --sensor: mini, r15, digit, raw); "
        "default: the protocol file's camera_profile, else raw.",
        show_default=False,
    ),
    open_timeout_s: options.OpenTimeout = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: options.ReadTimeout = TRIAL_READ_TIMEOUT_S,
    warmup_timeout_s: options.WarmupTimeout = DEFAULT_WARMUP_TIMEOUT_S,
) -> None:
    """Run one trial on a robot: grasp, lift, record, push, hold, lower, release.

    The cameras are opened first; then the gripper grasps the bottle, the arm lifts
    it, the recording starts, the arm pushes, holds still for the ring-down, and the
    bottle is put down and released. meta.json gets the protocol, the push's times
    and the arm's and gripper's readings. On any error or Ctrl-C the arm stops, the
    gripper KEEPS holding the bottle (put it down yourself) and no trial is written.
    """
    from liquidtouch._core.progress import on_terminal
    from liquidtouch.acquire.protocol_params import (
        ProtocolParameters,
        load_protocol,
        protocol_from_mapping,
    )
    from liquidtouch.errors import LiquidTouchError
    from liquidtouch.io.labels import typed_labels

    params = load_protocol(protocol) if protocol is not None else ProtocolParameters()
    if seconds is not None:
        if not math.isfinite(seconds):
            raise LiquidTouchError(f"--seconds must be a finite number, got {seconds}")
        params = protocol_from_mapping({**params.model_dump(), "hold_s": seconds}, "--seconds")
    if sensor is not None:
        params = protocol_from_mapping(
            {**params.model_dump(), "camera_profile": str(sensor)}, "--sensor"
        )
    labels = {k: v for k, v in typed_labels(label).items() if v is not None}
    if name and len(name) != len(camera):
        raise LiquidTouchError(f"{len(camera)} --camera but {len(name)} --name")
    verbose = on_terminal() and not as_json

    def on_step(step: str) -> None:
        if verbose:
            print(f"{step} ...", file=sys.stderr, flush=True)

    from liquidtouch.acquire.protocol import make_recorder

    live_run = None
    factory = functools.partial(
        make_recorder,
        open_timeout_s=open_timeout_s,
        read_timeout_s=read_timeout_s,
        warmup_timeout_s=warmup_timeout_s,
    )
    if live or model_file is not None or serve or until_std:
        from liquidtouch.cli.live_trial import LiveTrial

        live_run = LiveTrial(
            name
            or ["left", "right"][: len(camera)] + [f"sensor{i}" for i in range(2, len(camera))],
            model_file=model_file,
            until_std=until_std,
            serve=serve,
            quiet=as_json,
        )
        factory = functools.partial(factory, on_frame=live_run.tap)
        live_run.start()
    try:
        run = _run(gripper, arm, camera, out, params, labels, name, on_step, factory, live_run)
    finally:
        if live_run is not None:
            live_run.end()
    if live_run is not None:
        live_run.write(run.trial_dir)
    _report(run, as_json, live_run)


def _run(gripper, arm, camera, out, params, labels, name, on_step, factory, live_run):
    from liquidtouch.acquire.arms import RigArm, open_arm
    from liquidtouch.acquire.grippers import open_gripper
    from liquidtouch.acquire.protocol import run_trial

    with open_gripper(gripper) as grip, open_arm(arm) as robot:
        extra: dict[str, object] = {}
        if isinstance(robot, RigArm):  # the simulated rig knows the truth
            truth = robot.truth()
            extra = {
                "true_decay_rate": truth["true_decay_rate"],
                "true_angular_frequency": truth["true_angular_frequency"],
                "simulated_rig": truth,
            }
        run = run_trial(
            grip,
            robot,
            camera,
            out,
            params,
            labels,
            names=name or None,
            extra_meta=extra,
            on_step=on_step,
            recorder_factory=factory,
            on_event=None if live_run is None else live_run.event,
        )
    return run


def _report(run, as_json: bool, live_run) -> None:
    summary = run.summary
    from liquidtouch.cli.format import warn

    for message in summary.warnings:
        warn(message)
    result = {
        "trial": str(run.trial_dir),
        "push_start_s": run.push_start_s,
        "push_end_s": run.push_end_s,
        "recording": summary.to_dict(),
    }
    if live_run is not None and live_run.final is not None:
        result["live"] = live_run.final
    if as_json:
        typer.echo(json.dumps(result, default=str))
        return
    for s in summary.sensors.values():
        fps = f"{s.measured_fps:.2f}" if s.measured_fps else "—"
        typer.echo(f"{s.name}: {s.frames} frames at {fps} fps, {s.drops} dropped ({s.source})")
    typer.echo(f"push {run.push_start_s:.2f}-{run.push_end_s:.2f} s; wrote {run.trial_dir}")
    if live_run is not None and live_run.final is not None:
        final = live_run.final
        typer.echo(
            f"live: λ = {final['decay_rate']} ± {final['decay_rate_std']} 1/s, "
            f"ω = {final['angular_frequency']} ± {final['angular_frequency_std']} rad/s "
            f"(segment {final['segment']}; {final['message'] or 'final'}); wrote live.json"
        )
