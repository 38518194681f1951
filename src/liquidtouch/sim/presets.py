"""The paper's datasets as simulator presets, and writing a whole dataset.

Each preset is a list of :class:`TrialSpec` (trial path, ``simulate_trial``
arguments, split, seed). Sizes and ranges follow Huang, Guo, Yuan (RSS 2022):

- ``classification``: water, olive oil, detergent in the grooved cuboid;
  train 8 fill heights evenly spanning 1/3-2/3 full (20-40 mm) per liquid,
  test 70 random heights (uniform 20-40 mm) per liquid.
- ``sugar``: sugar water in the grooved cuboid; train 9 concentrations 0-160
  (step 20) × 12 heights 16-40 mm = 108; test 8 concentrations 10-150 × the
  12 heights × 3 repeats = 288.
- ``other-liquids``: olive oil, corn oil, mirin × 12 heights 16-40 mm × 3
  repeats = 108, all test (the sugar-water models are applied to them).
- ``containers``: sugar water as in ``sugar`` (train 9 concentrations 0-160,
  test 8 concentrations 10-150) in the cylinder (13 heights 12-35 mm: 117 /
  104), the cuboid (12 heights 15-38 mm: 108 / 96) and the glass container
  (7 heights 22-39 mm: 63 / 56).
- ``force-torque``: the classification protocol again (its own seeds); the
  experiment reads each trial's ``wrench.csv`` (wrist F/T) instead of the gels.

``quick=True`` keeps a deterministic random subset (fixed seed) of each
(group, split): a few dozen trials per preset, for the ``--quick`` reproduction.
"""

from __future__ import annotations

import logging
import os
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from liquidtouch._core.checks import check_int
from liquidtouch._core.pool import open_executor, run_each
from liquidtouch._core.progress import progress_bar
from liquidtouch.errors import CatalogueError, DatasetError, OutputError
from liquidtouch.io.dataset import write_manifest
from liquidtouch.sim.realism import Realism, get_realism
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import check_trial_dir, write_trial

__all__ = [
    "CLASS_LIQUIDS",
    "CONTAINER_HEIGHTS_MM",
    "OTHER_LIQUIDS",
    "PRESETS",
    "QUICK_SIZES",
    "SUGAR_HEIGHTS_MM",
    "TEST_CONCENTRATIONS",
    "TRAIN_CONCENTRATIONS",
    "DatasetResult",
    "TrialSpec",
    "get_preset",
    "preset_names",
    "run_spec",
    "simulate_dataset",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrialSpec:
    """One trial of a preset: where it goes, how to simulate it, its split and seed."""

    name: str  # path relative to the dataset root, e.g. "train/c040_h16.0_r0"
    kwargs: dict[str, Any]  # keyword arguments of simulate_trial (without seed)
    split: str  # "train" or "test"
    seed: int
    group: str = ""  # sub-experiment (e.g. the container), for subsampling


@dataclass
class DatasetResult:
    """What :func:`simulate_dataset` wrote."""

    root: Path
    manifest: Path
    n_trials: int
    failures: list[tuple[str, str]] = field(default_factory=list)  # (trial, error message)


TRAIN_CONCENTRATIONS = np.linspace(0.0, 160.0, 9)
TEST_CONCENTRATIONS = np.linspace(10.0, 150.0, 8)
SUGAR_HEIGHTS_MM = np.linspace(16.0, 40.0, 12)
CONTAINER_HEIGHTS_MM = {
    "cylinder": np.linspace(12.0, 35.0, 13),
    "cuboid": np.linspace(15.0, 38.0, 12),
    "glass": np.linspace(22.0, 39.0, 7),
}
CLASS_LIQUIDS = ("water", "olive-oil", "detergent")
OTHER_LIQUIDS = ("olive-oil", "corn-oil", "mirin")
QUICK_SIZES = {  # (train, test) kept per group with quick=True: ~220 trials in all
    "classification": (8, 10),
    "sugar": (36, 24),
    "other-liquids": (0, 6),
    "containers": (18, 10),
    "force-torque": (8, 10),
}


def _seed(preset: str, index: int) -> int:
    return (zlib.crc32(preset.encode()) + 7919 * index) % (2**31)


def _sugar_specs(prefix: str, container: str, heights: np.ndarray) -> list[tuple]:
    out = []
    for c in TRAIN_CONCENTRATIONS:
        for h in heights:
            out.append((f"{prefix}train/c{c:03.0f}_h{h:04.1f}", c, h, "train"))
    for c in TEST_CONCENTRATIONS:
        for h in heights:
            for r in range(3 if container == "grooved-cuboid" else 1):
                suffix = f"_r{r}" if container == "grooved-cuboid" else ""
                out.append((f"{prefix}test/c{c:03.0f}_h{h:04.1f}{suffix}", c, h, "test"))
    return out


def _build(preset: str) -> list[TrialSpec]:
    rows: list[tuple[str, dict[str, Any], str, str]] = []
    if preset in ("classification", "force-torque"):
        rng = np.random.default_rng(_seed(preset, 10**6))
        for liquid in CLASS_LIQUIDS:
            for h in np.linspace(20.0, 40.0, 8):
                kw = {"liquid": liquid, "height_mm": round(float(h), 2)}
                rows.append((f"train/{liquid}_h{h:04.1f}", kw, "train", liquid))
            for i, h in enumerate(rng.uniform(20.0, 40.0, 70)):
                kw = {"liquid": liquid, "height_mm": round(float(h), 2)}
                rows.append((f"test/{liquid}_{i:02d}_h{h:04.1f}", kw, "test", liquid))
    elif preset == "sugar":
        for name, c, h, split in _sugar_specs("", "grooved-cuboid", SUGAR_HEIGHTS_MM):
            kw = {"liquid": "sugar-water", "sugar_concentration": float(c), "height_mm": float(h)}
            rows.append((name, kw, split, "grooved-cuboid"))
    elif preset == "other-liquids":
        for liquid in OTHER_LIQUIDS:
            for h in SUGAR_HEIGHTS_MM:
                for r in range(3):
                    kw = {"liquid": liquid, "height_mm": float(h)}
                    rows.append((f"test/{liquid}_h{h:04.1f}_r{r}", kw, "test", liquid))
    elif preset == "containers":
        for container, heights in CONTAINER_HEIGHTS_MM.items():
            for name, c, h, split in _sugar_specs(f"{container}/", container, heights):
                kw = {
                    "liquid": "sugar-water",
                    "sugar_concentration": float(c),
                    "height_mm": round(float(h), 2),
                    "container": container,
                }
                rows.append((name, kw, split, container))
    else:
        raise CatalogueError(f"unknown preset {preset!r}; known presets: {', '.join(PRESETS)}")
    return [
        TrialSpec(name, kw, split, _seed(preset, i), group)
        for i, (name, kw, split, group) in enumerate(rows)
    ]


PRESETS: dict[str, str] = {
    "classification": "water / olive oil / detergent, 8 train + 70 test heights each",
    "sugar": "sugar water 0-160 g/100 g × 16-40 mm (108 train, 288 test)",
    "other-liquids": "olive oil, corn oil, mirin × 12 heights × 3 (108 test)",
    "containers": "sugar water in cylinder, cuboid, glass (288 train, 256 test)",
    "force-torque": "the classification protocol, for the wrist F/T comparison",
}


def preset_names() -> list[str]:
    """Names of the presets."""
    return list(PRESETS)


def get_preset(name: str, *, quick: bool = False) -> list[TrialSpec]:
    """The trial specs of preset ``name``; ``quick`` keeps a small deterministic subset."""
    specs = _build(name)
    if not quick:
        return specs
    keep_train, keep_test = QUICK_SIZES[name]
    rng = np.random.default_rng(_seed(name, -1))
    kept: list[TrialSpec] = []
    for group in dict.fromkeys(s.group for s in specs):
        for split, keep in (("train", keep_train), ("test", keep_test)):
            members = [s for s in specs if s.group == group and s.split == split]
            if len(members) > keep:
                idx = np.sort(rng.choice(len(members), keep, replace=False))
                members = [members[i] for i in idx]
            kept += members
    return kept


def run_spec(
    spec: TrialSpec,
    root: str,
    video: bool,
    sensor: str = "default",
    realism: Realism | str | None = None,
    after: Callable[[str, str], object] | None = None,
) -> dict[str, Any]:
    """Simulate and write one trial; return its manifest row (used by worker processes).

    ``realism`` is the world (:mod:`liquidtouch.sim.realism`; default clean).
    ``after(root, trial name)`` runs once the trial is written (see :func:`simulate_dataset`).

    The trial directory is checked before the simulation and replaced as a
    whole at the end (:func:`~liquidtouch.sim.trial_io.write_trial`).
    """

    check_trial_dir(Path(root) / spec.name)
    trial = simulate_trial(seed=spec.seed, realism=realism, **spec.kwargs)
    write_trial(trial, Path(root) / spec.name, video=video, sensor=sensor)
    if after is not None:
        after(root, spec.name)
    return {"trial": spec.name, "split": spec.split, **trial.labels()}


def _prune_empty_dirs(root: Path, *, remove_root: bool) -> None:
    """Remove the empty directories under ``root`` (and ``root`` itself if asked)."""
    for current, _, _ in sorted(os.walk(root), key=lambda entry: -len(entry[0])):
        if current == str(root) and not remove_root:
            continue
        try:
            os.rmdir(current)  # fails, harmlessly, unless empty
        except OSError:
            pass


def simulate_dataset(
    preset: str | list[TrialSpec],
    out_dir: str | Path,
    *,
    jobs: int = 1,
    video: bool = True,
    quick: bool = False,
    progress: bool = True,
    sensor: str = "default",
    realism: Realism | str | None = None,
    after_trial: Callable[[str, str], object] | None = None,
) -> DatasetResult:
    """Simulate every trial of ``preset`` into ``out_dir`` and write ``manifest.csv``.

    Runs on ``jobs`` worker processes when ``jobs > 1``. A failing trial does
    not stop the batch: it is left out of the manifest and listed in
    ``DatasetResult.failures``; only a batch where every trial fails raises
    :class:`DatasetError`. The preset, ``jobs``, ``sensor`` and ``out_dir``
    are checked before anything is written. Each trial directory is written
    atomically (built beside its place, then renamed in), and ``manifest.csv``
    last: after a failure or Ctrl-C the trials already finished are complete,
    no trial is half-written, and the manifest is not (re)written.
    ``realism`` adds a real bench's nuisances to every trial (``"lab"`` or a
    :class:`~liquidtouch.sim.realism.Realism`; default clean), recorded in each
    trial's ``meta.json``. ``after_trial(out_dir, trial name)`` (picklable) runs in
    the worker right after each trial is written, as part of its task: e.g.
    ``liquidtouch.batch.features.cache_trial_features`` extracts the trial while
    its videos are in the page cache, overlapping simulation and extraction.
    """

    specs = get_preset(preset, quick=quick) if isinstance(preset, str) else list(preset)
    check_int(jobs, "`jobs`", 1, DatasetError)
    get_sensor_profile(sensor)
    world = get_realism(realism)
    if str(out_dir) == "":
        raise OutputError("cannot write an empty path; give a dataset directory")
    root = Path(out_dir)
    created = not root.exists()
    if root.exists() and not root.is_dir():
        raise OutputError(
            f"cannot write {root}: it exists and is not a directory; choose a directory path"
        )
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(
            f"cannot create {root}: {exc.strerror or exc}; choose another output path"
        ) from None
    rows: dict[str, dict[str, Any]] = {}
    failures: list[tuple[str, str]] = []

    try:
        with (
            open_executor(jobs, n_tasks=len(specs)) as pool,
            progress_bar("simulating trials", len(specs), enabled=progress) as advance,
        ):
            tasks = {
                spec.name: (spec, str(root), video, sensor, world, after_trial) for spec in specs
            }
            for name, future in run_each(pool, run_spec, tasks):
                try:
                    rows[name] = future.result()
                    logger.info("trial %s simulated", name)
                except Exception as exc:  # a bad trial must not kill the batch
                    logger.warning("trial %s failed: %s: %s", name, type(exc).__name__, exc)
                    failures.append((name, f"{type(exc).__name__}: {exc}"))
                advance()
    except BaseException:  # Ctrl-C: remove the directories this call made and left empty
        _prune_empty_dirs(root, remove_root=created)
        raise
    if not rows:
        first = failures[0][1] if failures else "no trials"
        raise DatasetError(f"every trial failed ({len(failures)}); first error: {first}")
    ordered = [rows[s.name] for s in specs if s.name in rows]
    manifest = write_manifest(root, ordered)
    return DatasetResult(root, manifest, len(ordered), failures)
