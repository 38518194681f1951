"""``liquidtouch fit``: JSON keys and values, table, plot, and one-line errors with exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.errors import TableError
from liquidtouch.fit.example import EXAMPLE_PARAMETERS, example_signal
from liquidtouch.io.signal_csv import read_signal_csv, write_signal_csv

KEYS = (
    "decay_rate",
    "angular_frequency",
    "fast_decay_rate",
    "fast_angular_frequency",
    "decay_rate_std",
    "angular_frequency_std",
    "fast_decay_rate_std",
    "fast_angular_frequency_std",
    "r2",
)


@pytest.fixture
def signal_csv(tmp_path):
    path = tmp_path / "signal.csv"
    write_signal_csv(path, *example_signal(seed=1))
    return path


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    assert captured.out == ""
    return lines[0]


@pytest.mark.parametrize("loss", ["paper", "ls"])
def test_fit_json_keys_and_values(signal_csv, capsys, loss: str) -> None:
    # the example signal starts at the release: --start 0 fits all of it (auto would cut at
    # the largest excursion, 1.1 s in, where the two modes beat, and lose the fast mode)
    # the example is the paper's two-mode model: fit that model
    args = ["fit", str(signal_csv), "--json", "--loss", loss, "--start", "0", "--model", "two-mode"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    for key in KEYS:
        assert isinstance(out[key], float), key
    p = EXAMPLE_PARAMETERS
    assert abs(out["decay_rate"] - p["decay_rate"]) < 4 * out["decay_rate_std"]
    assert abs(out["angular_frequency"] - p["angular_frequency"]) < 4 * out["angular_frequency_std"]
    assert out["loss"] == loss and out["model"] == "two-mode"


def test_single_mode_json_has_null_fast_mode(signal_csv, capsys) -> None:
    assert main(["fit", str(signal_csv), "--json", "--model", "single-mode"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["model"] == "single-mode" and out["fast_decay_rate"] is None
    assert set(KEYS) <= set(out)


def test_fit_table_and_plot(signal_csv, tmp_path, capsys) -> None:
    png = tmp_path / "plots" / "fit.png"
    assert main(["fit", str(signal_csv), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "slow" in out and "fast" in out and "R²" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in png.parent.iterdir()] == ["fit.png"]  # no temp file left


def test_fit_builtin_example(capsys) -> None:
    assert main(["fit", "--example", "--json", "--model", "two-mode"]) == 0  # its model
    out = json.loads(capsys.readouterr().out)
    assert abs(out["decay_rate"] - EXAMPLE_PARAMETERS["decay_rate"]) < 4 * out["decay_rate_std"]


def test_signal_csv_round_trip(tmp_path) -> None:
    t, u = example_signal()
    write_signal_csv(tmp_path / "s.csv", t, u)
    t2, u2 = read_signal_csv(tmp_path / "s.csv")
    np.testing.assert_allclose(t2, t, rtol=1e-8)
    np.testing.assert_allclose(u2, u, rtol=1e-8, atol=1e-12)
    with pytest.raises(TableError):
        write_signal_csv(tmp_path / "bad.csv", t, u[:-1])


def _csv(tmp_path, text: str):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return str(path)


def _rows(f) -> str:
    t = np.arange(390) / 30
    return "".join(f"{a},{b}\n" for a, b in zip(t, f(t), strict=True))


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("time,value\n0,1\n1,2\n", "missing column"),
        ("t,u\n0,1\n0.1,abc\n0.2,3\n", "non-numeric"),
        ("t,u\n0,1\n0.1,\n0.2,3\n", "column 'u'"),
        ("t,u\n0,1\n0.1,nan\n0.2,3\n", "NaN"),
        ("", "not a readable CSV"),
        ("t,u\n" + _rows(lambda t: 0 * t + 1.0), "flat"),
        ("t,u\n" + _rows(lambda t: np.cos(9 * t))[:200], "too short"),
        ("t,u\n" + _rows(lambda t: np.random.default_rng(0).normal(size=t.size)), "no push found"),
        ("t,u\n" + _rows(lambda t: np.exp(-t / 0.7)), "overdamped"),
        ("t,u\n1,1\n0,2\n" + _rows(lambda t: np.cos(9 * t)), "increase strictly"),
    ],
)
def test_bad_signal_csv_is_one_error_line(tmp_path, capsys, content: str, match: str) -> None:
    assert main(["fit", _csv(tmp_path, content), "--json"]) == 2
    assert match in one_error_line(capsys)


@pytest.mark.parametrize(
    "args",
    [
        ["fit", "/nonexistent/signal.csv"],
        ["fit"],
        ["fit", "--example", "--loss", "l1"],
        ["fit", "--example", "--model", "three"],
        ["fit", "--example", "--band-low", "9", "--band-high", "2"],
    ],
)
def test_bad_arguments_are_one_error_line(capsys, args: list[str]) -> None:
    assert main(args) == 2
    one_error_line(capsys)


def test_signal_and_example_together_is_an_error(signal_csv, capsys) -> None:
    assert main(["fit", str(signal_csv), "--example"]) == 2
    assert "exactly one" in one_error_line(capsys)


def test_help_documents_options(capsys) -> None:
    assert main(["fit", "--help"]) == 0
    out = capsys.readouterr().out
    for option in ("--json", "--loss", "--model", "--plot"):
        assert option in out


def test_signal_csv_reader_and_writer_check_their_input(tmp_path) -> None:
    with pytest.raises(TableError, match="is a directory; give a signal CSV file"):
        read_signal_csv(tmp_path)
    with pytest.raises(FileNotFoundError):
        read_signal_csv(tmp_path / "missing.csv")
    (tmp_path / "header.csv").write_text("t,u\n")
    with pytest.raises(TableError, match="no data rows"):
        read_signal_csv(tmp_path / "header.csv")
    t = np.arange(5.0)
    with pytest.raises(TableError, match=r"u holds 1 NaN/inf value\(s\) \(first at sample 2\)"):
        write_signal_csv(tmp_path / "nan.csv", t, np.array([0, 1, np.nan, 3, 4.0]))
    with pytest.raises(TableError, match="t holds 1 NaN/inf"):
        write_signal_csv(tmp_path / "inf.csv", np.r_[t[:-1], np.inf], t)
    with pytest.raises(TableError, match="real numbers"):
        write_signal_csv(tmp_path / "text.csv", ["a", "b"], [1.0, 2.0])
    with pytest.raises(TableError, match="1-D of equal length"):
        write_signal_csv(tmp_path / "2d.csv", np.zeros((2, 2)), np.zeros((2, 2)))
    assert [p.name for p in tmp_path.iterdir()] == ["header.csv"]  # nothing written


def test_cli_and_api_give_the_same_lambda_and_omega_by_default(tmp_path, capsys) -> None:
    """``fit_oscillation(t, u)`` and ``liquidtouch fit`` share one default (issue 23).

    A paper-model signal with two close modes (where the old command-line default,
    the amplitude model, collapsed λ) after 1.5 s at rest: the command's
    ``--start auto`` finds the release, the API is given the ring-down from there.
    """
    from liquidtouch.fit.oscillation import fit_oscillation

    rng = np.random.default_rng(11)
    t = np.arange(0.0, 14.5, 1 / 30)
    tau = np.maximum(t - 1.5, 0.0)
    u = np.exp(-0.055 * tau) * np.cos(9.0 * tau) + 1.2 * np.exp(-1.0 * tau) * np.cos(9.5 * tau)
    u = np.where(t >= 1.5, u, 0.0) + rng.normal(0, 0.02, t.size)
    path = tmp_path / "u.csv"
    write_signal_csv(path, t, u)
    t, u = read_signal_csv(path)
    assert main(["fit", str(path), "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert cli["t0"] == pytest.approx(1.5, abs=0.02)
    free = t >= cli["t0"]
    api = fit_oscillation(t[free], u[free])
    assert cli["decay_rate"] == pytest.approx(api.decay_rate, rel=1e-9)
    assert cli["angular_frequency"] == pytest.approx(api.angular_frequency, rel=1e-9)
    assert cli["model"] == api.model == "two-mode"
    assert api.decay_rate == pytest.approx(0.055, rel=0.08)  # the truth, not a collapse
    assert cli["model_reason"].startswith("auto; lowest BIC")
    assert cli["delta_bic_two_mode"] == 0.0 and cli["delta_bic_amplitude"] > 0
    assert main(["fit", str(path)]) == 0
    assert "model: two-mode (auto; lowest BIC" in capsys.readouterr().out
