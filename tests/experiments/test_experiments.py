"""The seven experiments and the report, on synthetic feature tables with known physics.

The tables (``liquidtouch.testing.experiment_tables``) come from the sloshing formulas of
``liquidtouch.testing.synthetic_tables`` (no video), so the test checks the experiments'
numbers against what such data allow, and that the report is complete and
self-contained.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from helpers import fewer_experiment_draws

from liquidtouch.experiments.reproduce import failure_note
from liquidtouch.experiments.suite import run_experiments
from liquidtouch.testing.experiment_tables import FAILED, NO_OSCILLATION, experiment_features


@pytest.fixture(scope="module")
def features() -> dict[str, dict[str, pd.DataFrame]]:
    return experiment_features()


@pytest.fixture(scope="module")
def report(synthetic_report: Path) -> tuple[Path, pd.DataFrame]:
    """The report of the seven experiments on ``features`` (conftest: built once per run)."""
    summary = pd.read_csv(synthetic_report / "summary.csv", keep_default_na=False, na_values=[""])
    return synthetic_report, summary


def _row(summary: pd.DataFrame, experiment: str, metric: str) -> pd.Series:
    row = summary[(summary["experiment"] == experiment) & (summary["metric"] == metric)]
    assert len(row) == 1, f"no headline {experiment!r} / {metric!r}"
    return row.iloc[0]


def _headline(summary: pd.DataFrame, experiment: str, metric: str) -> float:
    return float(_row(summary, experiment, metric)["ours"])


def test_classification_counts_the_failed_trial_as_wrong(report) -> None:
    _, summary = report
    accuracy = _headline(summary, "classification", "test accuracy")
    # 30 test trials, one without features: at best 29/30
    assert 90.0 <= accuracy <= 100 * 29 / 30 + 1e-9
    assert (
        "1 without features (counted wrong)"
        in _row(summary, "classification", "test accuracy")["note"]
    )


def test_wrist_ft_zero_is_explained_not_bare(report) -> None:
    """0 % with three classes reads as a bug unless the row says what happened."""
    out, summary = report
    row = _row(summary, "force-torque", "wrist F/T accuracy")
    from liquidtouch.experiments.paper import FORCE_TORQUE_ACCURACY

    assert row["ours"] == 0.0
    assert row["paper"] == pytest.approx(FORCE_TORQUE_ACCURACY["wrist F/T"].value)
    assert "30/30 test" in row["note"] and "no classifier could be trained" in row["note"]
    assert NO_OSCILLATION in row["note"] and "chance is 33 %" in row["note"]
    assert (out / "force_torque.png").is_file()  # a figure even with no wrist classifier


def test_wrist_ft_best_effort_fit_is_classified_like_the_paper(report) -> None:
    """The paper's comparison: the wrist fit forced through the noise, then classified."""
    _, summary = report
    row = _row(summary, "force-torque", "wrist F/T, best-effort fit accuracy")
    assert row["paper"] == pytest.approx(34.3)
    # features that carry no information about the liquid: near chance (1 in 3) on
    # 30 test trials, never near the GelSight's accuracy
    assert 10.0 <= row["ours"] <= 60.0
    assert "chance is 33 %" in row["note"]


def test_every_summary_row_has_a_unit_and_paper_numbers_their_source(report) -> None:
    _, summary = report
    assert len(summary) >= 29
    assert (summary["unit"].astype(str).str.strip() != "").all(), summary[["metric", "unit"]]
    with_paper = summary[summary["paper"].notna()]
    assert len(with_paper) >= 20
    assert (with_paper["paper source"].astype(str).str.strip() != "").all()
    units = dict(zip(summary["metric"], summary["unit"], strict=True))
    assert units["gpr test MAE c"] == "g/100 g water"
    assert units["gpr test MAE μ"] == "log10 cSt"
    assert units["gpr test MAE h"] == "mm"


def test_regression_errors_match_what_the_data_allow(report) -> None:
    _, summary = report
    # features carry 4 % noise on λ and 0.3 % on ω (synthetic_tables); a guess of the
    # mean would give about 6 mm / 45 g/100 g water / 0.45
    assert _headline(summary, "sugar", "gpr test MAE h") < 0.4
    assert _headline(summary, "sugar", "gpr test MAE c") < 6.0
    assert _headline(summary, "sugar", "gpr test MAE μ") < 0.06
    assert _headline(summary, "sugar", "quadratic test MAE h") < 0.6
    for container in ("cylinder", "cuboid", "glass"):
        assert _headline(summary, "containers", f"{container} MAE h") < 0.5
    # oils beyond the sugar range (ν up to 59 cSt): height still within a millimetre
    assert _headline(summary, "other liquids", "mirin h MAE") < 1.0


def test_data_efficiency_curves_have_several_points(report) -> None:
    out, _ = report
    table = pd.read_csv(out / "data_efficiency.csv")
    points = table.groupby(["container", "model"])["n train"].agg(["count", "max"])
    assert len(points) == 8  # 4 containers x 2 models
    assert (points["count"] >= 4).all(), points
    # the last point of each curve is the whole training set
    assert points.loc[("glass", "gpr"), "max"] == 54


def test_transfer_beats_the_untuned_model(report) -> None:
    out, summary = report
    table = pd.read_csv(out / "transfer.csv")
    transferred = table[(table["method"] == "transfer") & (table["n tuning"] == 15)]
    untuned = re.search(r"model gives h MAE ([\d.]+) mm", (out / "report.md").read_text())
    assert untuned is not None
    assert float(transferred["h [mm]"].iloc[0]) < 0.2 * float(untuned.group(1))
    assert _headline(summary, "transfer", "transfer, 15 points: h MAE") < 1.0


def test_calibration_section(report) -> None:
    """Experiment 8: the calibrated ± cover the sugar-water test trials near their level."""
    out, _ = report
    table = pd.read_csv(out / "calibration.csv")
    sugar = table[table["data"] == "sugar water (test)"]
    assert set(sugar["target"]) == {"h [mm]", "μ [log10 cSt]"}
    assert (sugar["±2σ [%]"] >= 80).all() and (sugar["rms z"] < 1.6).all()
    assert (out / "calibration.png").is_file()


def test_report_is_complete_and_self_contained(report) -> None:
    out, _ = report
    page = (out / "report.html").read_text()
    for number in range(1, 9):
        assert f"<h2>{number}. " in page
    images = re.findall(r"<img[^>]*src='([^']*)'", page)
    assert len(images) == 8  # one figure per experiment, the wrist F/T included
    assert all(src.startswith("data:image/png;base64,") for src in images)
    assert not re.search(r"(src|href)=['\"]https?:", page)
    assert "1 without features" in page  # the failed classification trial is reported
    assert "<h2>Provenance</h2>" in page and "none (test)" in page
    markdown = (out / "report.md").read_text()
    assert "## Provenance" in markdown
    for figure in re.findall(r"!\[[^]]*\]\(([^)]+)\)", markdown):
        assert (out / figure).is_file()
    for text in (page, markdown, (out / "summary.csv").read_text()):
        assert "wt%" not in text and "wt %" not in text


def test_text_columns_left_numbers_right(report) -> None:
    out, _ = report
    page = (out / "report.html").read_text()
    summary = re.search(r"<table class='summary'>.*?</table>", page, re.S).group(0)
    header = re.findall(r"<th([^>]*)>([^<]*)</th>", summary)
    aligned = {name: "num" in attrs for attrs, name in header}
    assert aligned == {
        "experiment": False, "metric": False, "ours": True, "paper": True, "unit": False,
        "note": False, "paper source": False,
    }  # fmt: skip
    markdown = (out / "report.md").read_text()
    assert "|:---|:---|---:|---:|:---|:---|:---|" in markdown


def test_an_experiment_the_data_cannot_support_is_reported_not_fatal(
    features, tmp_path, monkeypatch
) -> None:
    classes = features["classification"]["gelsight"]
    few = classes.groupby(["liquid", "split"]).head(2)  # 2 training trials per liquid
    thin = {
        **features,
        "classification": {"gelsight": few, "wrench": features["classification"]["wrench"]},
    }
    fewer_experiment_draws(monkeypatch)  # the claim is about experiment 1, not the curves
    results = run_experiments(thin, tmp_path)
    titles = [r.title for r in results]
    assert titles[0] == "1. Liquid classification (not run)"
    assert "at least 3 rows per class" in results[0].summary
    # 1 and 2 (the GelSight part), and 9: no recordings to replay beside synthetic tables
    assert sum(title.endswith("(not run)") for title in titles) == 3
    assert titles[-1] == "9. Time to answer, streamed (ours) (not run)"
    assert results[2].headlines  # sugar water and the rest still ran


def test_failure_note_counts_per_dataset() -> None:
    ok = pd.DataFrame({"error": ["", ""]})
    bad = pd.DataFrame({"error": ["", FAILED, FAILED]})
    note = failure_note({"sugar": {"gelsight": ok}, "containers": {"gelsight": bad}})
    assert note.startswith("Trials: sugar 2 trials; containers 3 trials (2 without features")


def test_provenance_names_versions_commit_and_machine() -> None:
    from liquidtouch.experiments.provenance import git_commit, provenance

    info = provenance(**{"base seed": 7})
    for key in ("liquidtouch", "git commit", "date", "base seed", "Python", "numpy",
                "scikit-learn", "OpenCV", "PyAV", "machine"):  # fmt: skip
        assert info[key], key
    assert info["base seed"] == "7" and "cores" in info["machine"]
    assert git_commit("/").startswith("none (")  # no checkout there: said, not raised


def test_seeded_specs_change_trial_seeds_only() -> None:
    from liquidtouch.experiments.reproduce import seeded_specs

    base = seeded_specs("sugar", quick=True, seed=0)
    other = seeded_specs("sugar", quick=True, seed=3)
    assert [s.name for s in base] == [s.name for s in other]
    assert [s.kwargs for s in base] == [s.kwargs for s in other]
    assert all(a.seed != b.seed for a, b in zip(base, other, strict=True))
    assert [s.seed for s in seeded_specs("sugar", quick=True, seed=3)] == [s.seed for s in other]


@pytest.mark.slow(seconds=100, exclusive=True)  # a pool of two workers
def test_reproduce_end_to_end_through_videos(tmp_path, monkeypatch) -> None:
    """The quick reproduction at a few trials per group: videos → … → report, then reused."""
    from typer.testing import CliRunner

    import liquidtouch.sim.presets as presets
    from liquidtouch.cli import app
    from liquidtouch.experiments.reproduce import reproduce

    sizes = {
        "classification": (3, 1),  # the classifier needs 3 trials per liquid
        "sugar": (8, 2),  # the quadratic model needs 7
        "other-liquids": (0, 1),
        "containers": (6, 1),
    }
    monkeypatch.setattr(presets, "QUICK_SIZES", {**presets.QUICK_SIZES, **sizes})
    out = tmp_path / "report"
    fewer_experiment_draws(monkeypatch)  # the experiments' own numbers: the tests above
    first = reproduce(out, quick=True, jobs=2, progress=False)
    page = first.report_html.read_text()
    assert (
        "Trials: classification 12 trials; sugar 10 trials; other-liquids 3 trials; containers"
        in page
    )
    assert "without features, e.g." not in page and "(not run)" not in page
    summary = first.summary.set_index("metric")["ours"]
    assert summary["test accuracy"] == pytest.approx(100.0)  # water / olive oil / detergent
    assert summary["gpr test MAE h"] < 3.0  # 8 training trials spanning 16-40 mm
    # the data live beside the report, not in it: the report directory can be shared
    assert first.data_dir == tmp_path / "report-data" / "quick-seed0"
    assert not any(p.suffix in (".mp4", ".avi", ".npz") for p in out.rglob("*"))
    assert sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) < 20e6
    features = pd.read_csv(first.data_dir / "sugar/features.csv")
    np.testing.assert_allclose(
        features["angular_frequency"], features["true_angular_frequency"], rtol=0.01
    )
    # experiment 9 replayed a sugar-water test trial through the live estimator
    assert "<h2>9. Time to answer, streamed (ours)</h2>" in page
    assert (out / "time_to_answer.png").is_file()
    assert "median ring-down time to a height within 1 mm for good" in summary.index
    # the F/T figure shows a trial's signals: it is wider than the accuracy bars alone
    from PIL import Image

    assert Image.open(out / "force_torque.png").size[0] > 1000
    # a second run (through the command line, --json) reuses the simulated data and features
    result = CliRunner().invoke(
        app, ["reproduce", "--quick", "--out", str(out), "--json", "-j", "1"]
    )
    assert result.exit_code == 0, result.output
    again = json.loads(result.stdout)
    assert "simulated in an earlier run" in Path(again["report_md"]).read_text()
    assert again["data_dir"] == str(first.data_dir.resolve())
    assert Path(again["summary_csv"]).is_file()
    ours = {row["metric"]: row["ours"] for row in again["summary"]}
    pd.testing.assert_series_equal(
        pd.Series(ours, name="ours").loc[summary.index], summary, check_names=False
    )


def _stop_before_the_report(monkeypatch, prepare_dataset) -> None:
    """A reproduction that runs no simulation or experiment: ``prepare_dataset`` stands in
    for the datasets, and writing the report fails (the command exits 2)."""
    import liquidtouch.experiments.reproduce as rep
    from liquidtouch.errors import LiquidTouchError

    def stop(*args, **kwargs):
        raise LiquidTouchError("stopped before the report (test)")

    monkeypatch.setattr(rep, "prepare_dataset", prepare_dataset)
    monkeypatch.setattr(rep, "run_experiments", lambda *a, **k: [])
    monkeypatch.setattr(rep, "write_report", stop)
    monkeypatch.setattr(rep, "failure_note", lambda features: "")


def test_demo_prints_a_line_per_stage_when_stderr_is_not_a_terminal(tmp_path, capsys, monkeypatch):
    """Campaign: `demo` piped into a log printed nothing for minutes."""
    import liquidtouch.experiments.reproduce as rep
    from liquidtouch.cli import main

    _stop_before_the_report(monkeypatch, lambda *a, **k: {})
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--out", "nowhere-report"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    stages = [line.split(" ", 1)[1] for line in lines[:-1]]
    assert [s.split(":")[0] for s in stages[: len(rep.DATASETS)]] == [
        f"dataset {i}/{len(rep.DATASETS)}" for i in range(1, len(rep.DATASETS) + 1)
    ]
    assert stages[-2:] == ["the experiments", "writing the report to nowhere-report"]
    assert lines[-1] == "error: stopped before the report (test)"


def test_reproduce_simulates_with_the_sensor_asked_for_and_keeps_its_data_apart(
    tmp_path, monkeypatch, capsys
):
    """`reproduce` simulates the GelSight Mini unless `--sensor` asks for another profile;
    the full size's data folder names the Mini (`full-seed0` held 640x480 data before), so
    no run reuses another profile's data; an unknown name is refused before anything is
    simulated."""
    import liquidtouch.experiments.reproduce as rep
    from liquidtouch.cli import main

    asked = []
    _stop_before_the_report(monkeypatch, lambda preset, root, **k: asked.append((root, k)))
    out = tmp_path / "report"
    for args, sensor, folder in [
        ([], "mini", "full-seed0-mini"),
        (["--sensor", "mini"], "mini", "full-seed0-mini"),
        (["--sensor", "default"], "default", "full-seed0"),
        (["--quick"], "mini", "quick-seed0"),
        (["--quick", "--sensor", "default"], "default", "quick-seed0-default"),
    ]:
        asked.clear()
        assert main(["reproduce", *args, "--out", str(out)]) == 2
        assert [k["sensor"] for _, k in asked] == [sensor] * len(rep.DATASETS), args
        assert {root.parent for root, _ in asked} == {tmp_path / "report-data" / folder}, args
    capsys.readouterr()
    assert main(["reproduce", "--sensor", "nope", "--out", str(tmp_path / "other")]) == 2
    assert "nope" in capsys.readouterr().err
    assert not (tmp_path / "other-data").exists() and not (tmp_path / "other").exists()
