"""``liquidtouch simulate``: simulated trials and the paper's datasets."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from liquidtouch.cli import options

simulate_app = typer.Typer(
    help="Simulate sloshing trials (loads, wrist wrench, GelSight videos) and whole datasets.",
    no_args_is_help=True,
)


Liquid = Annotated[
    str,
    typer.Option("--liquid", help="water, olive-oil, corn-oil, mirin, detergent or sugar-water."),
]
HeightMm = Annotated[
    float,
    typer.Option("--height-mm", help="Fill height [mm], above 0 and below the container's height."),
]
TrialOut = Annotated[
    Path,
    typer.Option(
        *options.OUT,
        file_okay=False,
        help="Trial directory to write: new, empty, or an existing trial (replaced as a whole).",
    ),
]
Container = Annotated[
    str,
    typer.Option("--container", help="grooved-cuboid, cuboid, cylinder, glass or upright-bottle."),
]
SugarConcentration = Annotated[
    float | None,
    typer.Option("--sugar-concentration", help="Sugar-water only: g sugar per 100 g water."),
]
Seed = Annotated[
    int,
    typer.Option(
        "--seed", help="Random seed (trial conditions and noise), an integer 0 to 2**63-1."
    ),
]
TemperatureC = Annotated[
    float | None,
    typer.Option(
        "--temperature-c", help="Liquid temperature, 0-60 °C (default: drawn around 21 °C)."
    ),
]
TrialVideo = Annotated[
    bool,
    typer.Option("--video/--no-video", help="Render the GelSight videos (left.mp4, right.mp4)."),
]
PushAxis = Annotated[
    str,
    typer.Option(
        "--push-axis",
        help="Push along x (the container's length) or y (across it; not a cylinder on its side).",
    ),
]
SimSensor = Annotated[str, typer.Option("--sensor", help="GelSight sensor profile name.")]
LoadsPlot = Annotated[
    bool, typer.Option("--plot", help="Also save loads.png in the trial directory.")
]
SimJson = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]


@simulate_app.command("trial")
def trial_command(
    liquid: Liquid,
    height_mm: HeightMm,
    out: TrialOut,
    container: Container = "grooved-cuboid",
    sugar_concentration: SugarConcentration = None,
    seed: Seed = 0,
    temperature_c: TemperatureC = None,
    video: TrialVideo = True,
    sensor: SimSensor = "default",
    gel: options.Gel = None,
    plot: LoadsPlot = False,
    realism: options.Realism = options.RealismChoice.clean,
    push_axis: PushAxis = "x",
    as_json: SimJson = False,
) -> None:
    """Simulate one trial (lift, lateral push, hold) and write meta.json, force.csv, wrench.csv.

    meta.json holds the labels and the ground truth: the small-amplitude decay
    rate and angular frequency of the slow slosh mode. Every argument is checked
    before anything is written, and the trial directory is built beside --out
    and renamed into place at the end: a failure or Ctrl-C leaves an existing
    trial there untouched.
    """
    from liquidtouch.sim.sensors import with_gel
    from liquidtouch.sim.trial import check_seed, simulate_trial
    from liquidtouch.sim.trial_io import check_trial_dir, write_trial

    check_seed(seed)
    sensor = with_gel(sensor, gel and gel.value)  # the profile with that gel (name checked)
    check_trial_dir(out)
    trial = simulate_trial(
        liquid,
        height_mm=height_mm,
        container=container,
        sugar_concentration=sugar_concentration,
        seed=seed,
        temperature_c=temperature_c,
        realism=realism.value,
        push_axis=push_axis,
    )
    directory = write_trial(trial, out, video=video, sensor=sensor, plot=plot)
    files = sorted(p.name for p in directory.iterdir() if not p.name.startswith("."))
    summary = {
        "trial": str(directory),
        "files": files,
        "realism": trial.realism.world,
        **trial.labels(),
    }
    if as_json:
        typer.echo(json.dumps(summary))
        return
    _print_trial(trial, directory, files)


def _print_trial(trial, directory: Path, files: list[str]) -> None:
    """What ``simulate trial`` wrote, and the trial's truth, in two lines."""
    typer.echo(
        f"wrote {directory}: {', '.join(files)}\n"
        f"  true decay rate {trial.true_decay_rate:.4f} 1/s, "
        f"angular frequency {trial.true_angular_frequency:.4f} rad/s, "
        f"viscosity {trial.viscosity_cst:.3g} cSt at {trial.temperature_c:.1f} °C "
        f"({trial.realism.world} world)"
    )


@simulate_app.command("dataset")
def dataset_command(
    preset: str = typer.Option(..., "--preset", help="Preset name (see 'simulate presets')."),
    out: Path = typer.Option(
        ..., *options.OUT, file_okay=False, help="Dataset directory to write (created if needed)."
    ),
    jobs: options.Jobs = 1,
    quick: bool = typer.Option(False, "--quick", help="A small deterministic subset."),
    video: bool = typer.Option(True, "--video/--no-video", help="Render GelSight videos."),
    sensor: str = typer.Option("default", "--sensor", help="GelSight sensor profile name."),
    gel: options.Gel = None,
    realism: options.Realism = options.RealismChoice.clean,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object on stdout."),
) -> None:
    """Simulate every trial of a preset (a dataset of the paper) and write manifest.csv.

    A failing trial is reported and left out; the rest are written. Each trial
    directory is written atomically and manifest.csv last, so after Ctrl-C the
    finished trials are complete and nothing is half-written.
    """
    from liquidtouch.sim.presets import simulate_dataset
    from liquidtouch.sim.sensors import with_gel

    progress = not as_json  # progress_bar itself draws only on a terminal
    result = simulate_dataset(
        preset,
        out,
        jobs=jobs,
        video=video,
        quick=quick,
        progress=progress,
        sensor=with_gel(sensor, gel and gel.value),
        realism=realism.value,
    )
    summary = {
        "root": str(result.root),
        "manifest": str(result.manifest),
        "n_trials": result.n_trials,
        "realism": realism.value,
        "failures": [{"trial": t, "error": e} for t, e in result.failures],
    }
    if as_json:
        typer.echo(json.dumps(summary))
        return
    typer.echo(f"wrote {result.n_trials} trials and {result.manifest} ({realism.value} world)")
    for name, error in result.failures:
        typer.echo(f"failed: {name}: {error}", err=True)


@simulate_app.command("presets")
def presets_command(
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object on stdout."),
) -> None:
    """List the dataset presets with their sizes (full and --quick)."""
    from liquidtouch.sim.presets import PRESETS, get_preset

    table = {}
    for name, description in PRESETS.items():
        full, quick = get_preset(name), get_preset(name, quick=True)
        table[name] = {
            "description": description,
            "train": sum(s.split == "train" for s in full),
            "test": sum(s.split == "test" for s in full),
            "quick": len(quick),
        }
    if as_json:
        typer.echo(json.dumps({"presets": table}))
        return
    for name, row in table.items():
        typer.echo(
            f"{name:15s} train {row['train']:4d}  test {row['test']:4d}  "
            f"quick {row['quick']:3d}  {row['description']}"
        )


def register(app: typer.Typer) -> None:
    """Register the ``simulate`` command group on ``app``."""
    app.add_typer(simulate_app, name="simulate")
