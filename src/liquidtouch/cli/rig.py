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

import json
import math
import sys
from typing import Annotated

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
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on."),
    gripper_port: Annotated[int, typer.Option(help="The gripper's TCP port; 0: any free.")] = 0,
    arm_port: Annotated[int, typer.Option(help="The arm's TCP port; 0: any free port.")] = 0,
    camera_port: Annotated[
        int, typer.Option(help="The left camera's HTTP port, the right one's the next; 0: any.")
    ] = 0,
    as_json: options.Json = False,
) -> None:
    """Serve a simulated rig until Ctrl-C: print the gripper, arm and camera URLs.

    The gripper is a WSG-50 on its text interface (wsg50://HOST:PORT), the arm a
    UR-like endpoint (sim://HOST:PORT), the two GelSight sensors MJPEG streams
    (http://HOST:PORT/stream). A push of the lifted bottle runs the simulator with
    that push; the liquid's true decay rate and angular frequency are printed (and
    answered by the arm's "truth" request). Give these URLs to run-trial.
    """
    from liquidtouch.sim.rig.rig import check_ports, serve_rig
    from liquidtouch.sim.rig.state import Rig
    from liquidtouch.sim.sensors import with_gel

    check_ports(gripper_port, arm_port, camera_port)
    rig = Rig(
        liquid, height_mm=height_mm, container=container, seed=seed,
        sensor=with_gel(sensor, gel and gel.value),
        sugar_concentration=sugar_concentration,
    )  # fmt: skip

    def show(endpoints: dict) -> None:
        if as_json:
            typer.echo(json.dumps(endpoints))
        else:
            truth = endpoints["truth"]
            typer.echo(f"gripper  {endpoints['gripper']}\narm      {endpoints['arm']}")
            for name, url in endpoints["cameras"].items():
                typer.echo(f"camera   {url}  ({name})")
            typer.echo(
                f"truth    λ = {truth['true_decay_rate']:.5f} 1/s, "
                f"ω = {truth['true_angular_frequency']:.4f} rad/s ({truth['liquid']}, "
                f"{truth['height_mm']:g} mm, {truth['container']}, seed {truth['seed']})"
                "\nserving; Ctrl-C stops"
            )
        sys.stdout.flush()

    serve_rig(rig, host, (gripper_port, arm_port, camera_port), on_ready=show)


def run_trial_command(
    gripper: options.GripperUrl,
    arm: options.ArmUrl,
    camera: options.Cameras,
    out: options.TrialOut,
    protocol: options.ProtocolFile = None,
    label: options.Labels = [],  # noqa: B006 - typer reads the default, never mutates it
    name: options.SensorNames = [],  # noqa: B006
    seconds: options.HoldSeconds = None,
    as_json: options.Json = False,
    model_file: options.LiveModel = None,
    live: bool = typer.Option(False, "--live", help="Estimate live (as --model, without one)."),
    serve: options.Serve = None,
    until_std: options.UntilStd = [],  # noqa: B006
    max_pushes: options.MaxPushes = None,
    plan: options.Plan = False,
    sensor: options.TrialSensor = None,
    recover: options.Recover = False,
    open_timeout_s: options.OpenTimeout = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: options.ReadTimeout = TRIAL_READ_TIMEOUT_S,
    warmup_timeout_s: options.WarmupTimeout = DEFAULT_WARMUP_TIMEOUT_S,
    tracking: options.Tracking = options.DEFAULT_TRACKING,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
) -> None:
    """Run one trial on a robot: grasp, lift, record, push, hold, return, lower, release.

    Every option is checked before anything is connected. A held bottle, an arm off its
    start pose or a gripper fault is refused or, with --recover, put right. The bottle ends
    where it started. --model/--live/--serve estimate live (live.json); --max-pushes pushes
    again until the answer is known or cannot be told. On any error or Ctrl-C the arm
    stops, the gripper KEEPS holding the bottle and no trial is written.
    """
    params, labels = _trial_options(protocol, seconds, sensor, max_pushes, label)
    if plan:
        return _plan(params, labels, model_file, until_std, as_json)
    asked = live or model_file is not None or bool(serve)
    live_run = _live_trial(name, len(camera), model_file, until_std, serve, params,
                           str(tracking), n_markers, asked=asked)  # fmt: skip
    from liquidtouch.acquire.bench import run_trial_at  # after the checks: it imports more

    timeouts = dict(open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s,
                    warmup_timeout_s=warmup_timeout_s)  # fmt: skip
    if live_run is not None:
        live_run.start()
    try:
        run = run_trial_at(
            gripper, arm, camera, out, params, labels, names=name, recover=recover,
            on_step=_progress(as_json), on_frame=None if live_run is None else live_run.tap,
            on_event=None if live_run is None else live_run.event,
            camera_timeouts=timeouts, decide=None if live_run is None else live_run.decide,
        )  # fmt: skip
    finally:
        if live_run is not None:
            live_run.end()
    if live_run is not None:
        live_run.write(run.trial_dir)
    _report(run, as_json, live_run)


def _trial_options(protocol, seconds, sensor, max_pushes, label: list[str]):
    """The trial's parameters (protocol file and options) and its typed labels, checked."""
    from liquidtouch.acquire.protocol_params import trial_parameters
    from liquidtouch.io.labels import typed_labels

    params = trial_parameters(protocol, hold_s=seconds, camera_profile=sensor,
                              max_pushes=max_pushes)  # fmt: skip
    return params, {k: v for k, v in typed_labels(label).items() if v is not None}


def _progress(as_json: bool):
    """``on_step`` printing each step on stderr, on a terminal and without --json."""
    from liquidtouch._core.progress import on_terminal

    if as_json or not on_terminal():
        return None
    return lambda step: print(f"{step} ...", file=sys.stderr, flush=True)


def _live_trial(names: list[str], n_cameras: int, model_file, until_std, serve, params,
                tracking: str, n_markers: int, *, asked: bool):  # fmt: skip
    """The live estimate beside the trial (its model, targets and pushes checked now), when
    ``asked`` (--live, --model, --serve), --until-std or --max-pushes want one; else None."""
    from liquidtouch.acquire.cameras.capture import default_names
    from liquidtouch.cli.live_trial import LiveTrial
    from liquidtouch.errors import LiquidTouchError

    if not (asked or until_std or params.max_pushes > 1):
        unused = (("--tracking", tracking, options.DEFAULT_TRACKING),
                  ("--markers", n_markers, options.DEFAULT_MARKERS))  # fmt: skip
        for flag, value, default in unused:
            if value != default:  # it would go unused: refused, not ignored
                raise LiquidTouchError(
                    f"{flag} {value} chooses how the live estimate reads the gels: add "
                    "--live (or --model); a recorded trial is read when it is extracted"
                )
        return None
    names = list(names) or default_names(n_cameras)
    return LiveTrial(names, model_file=model_file, until_std=until_std, serve=serve,
                     max_pushes=params.max_pushes, tracking=tracking,
                     n_markers=n_markers)  # fmt: skip


def _plan(params, labels: dict, model_file, until_std: list[str], as_json: bool) -> None:
    """``run-trial --plan``: the proposed push for the container, printed; nothing moves."""
    from liquidtouch.errors import LiquidTouchError
    from liquidtouch.live.stopping import parse_until_std
    from liquidtouch.models.modelfile import load_model
    from liquidtouch.planning.push import plan_push

    container = labels.get("container") or params.container
    if container is None:
        raise LiquidTouchError(
            "--plan needs the container: --label container=NAME or the protocol file's container"
        )
    if not until_std:
        raise LiquidTouchError("--plan needs --until-std TARGET=STD: the ± the push should reach")
    target, asked = next(iter(parse_until_std(until_std).items()))
    model = load_model(model_file) if model_file is not None else None
    limits = {k: getattr(params, k) for k in ("push_distance_mm", "push_speed_m_s",
                                              "push_acceleration_m_s2")}  # fmt: skip
    found = plan_push(str(container), target, asked, model=model, limits=limits)
    if as_json:
        typer.echo(json.dumps(found.to_dict()))
        return
    typer.echo("\n".join(found.lines()))
    typer.echo("protocol file lines:")
    for key, value in found.protocol_values().items():
        typer.echo(f"{key} = {json.dumps(value)}")


def _report(run, as_json: bool, live_run) -> None:
    from liquidtouch.cli.format import warn
    from liquidtouch.cli.live import answer_line

    summary = run.summary
    for message in summary.warnings:
        warn(message)
    result = {
        "trial": str(run.trial_dir),
        "push_start_s": run.push_start_s,
        "push_end_s": run.push_end_s,
        "pushes": run.pushes,
        "recording": summary.to_dict(),
    }
    final = None if live_run is None else live_run.final
    if final is not None:
        result["live"] = final
    if as_json:
        typer.echo(json.dumps(result, default=str))
        return
    for s in summary.sensors.values():
        fps = f"{s.measured_fps:.2f}" if s.measured_fps else "—"
        typer.echo(f"{s.name}: {s.frames} frames at {fps} fps, {s.drops} dropped ({s.source})")
    typer.echo(f"push {run.push_start_s:.2f}-{run.push_end_s:.2f} s; wrote {run.trial_dir}")
    if len(run.pushes) > 1:
        typer.echo(f"{len(run.pushes)} pushes, the last at {run.pushes[-1]['push_start_s']:.2f} s")
    if final is not None:
        typer.echo(f"{live_line(final)}; wrote live.json")
        if (answer := answer_line(final)) is not None:
            typer.echo(answer)


def live_line(final: dict) -> str:
    """The live estimate's final update in one line: λ, ω and every predicted target, each
    rounded to its std (``1.234 ± 0.012``), the liquid with its probability."""
    from liquidtouch._core.numbers import with_uncertainty

    if "error" in final:
        return f"live: the estimate failed: {final['error']}"

    def value(key: str) -> str:
        mean, std = final.get(key), final.get(f"{key}_std")
        return with_uncertainty(
            math.nan if mean is None else mean, math.nan if std is None else std
        )

    parts = [f"λ = {value('decay_rate')} 1/s", f"ω = {value('angular_frequency')} rad/s"]
    for key, mean in final.items():
        target = key.removeprefix("predicted_")
        if key == target or target.endswith(("_std", "_lower", "_upper")):
            continue
        if isinstance(mean, str):
            share = final.get(f"probability_{mean}")
            parts.append(f"{target} = {mean}" + (f" (p {share:.2f})" if share else ""))
        else:
            parts.append(f"{target} = {value(key)}")
    why = final.get("message") or "final"
    return f"live: {', '.join(parts)} (segment {final.get('segment')}; {why})"
