"""The Python package against the `hal-sim` CLI on the same data: both run the same Rust code,
so the numbers must agree to rounding (1e-12 relative) and the replay estimates exactly (the CSV
files print the shortest round-trip representation of each f64)."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import imu_ident
from conftest import run_cli

RTOL = 1e-12


# Columns of text even when every cell is empty (params.csv's flagged quantities).
TEXT_COLUMNS = {"not_identifiable"}


def read_csv(path: Path):
    """A CSV with a header as a dict of columns: floats as arrays (empty cell = NaN), other
    columns (and those in TEXT_COLUMNS) as lists of str."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    cols = {}
    for name in rows[0].keys() if rows else []:
        vals = [r[name] for r in rows]
        if name in TEXT_COLUMNS:
            cols[name] = vals
            continue
        try:
            cols[name] = np.array([float(v) if v != "" else np.nan for v in vals])
        except ValueError:
            cols[name] = vals
    return cols


def read_log(path: Path):
    cols = read_csv(path)
    truth = {k: cols["true_" + k] for k in ("dv", "delta", "da", "dw")}
    return cols["t"], cols["z"], truth


@pytest.fixture(scope="module")
def sim_log(tmp_path_factory, hal_sim):
    """Two hours of the `paper` scenario from the CLI (enough for the adaptive loop to
    re-identify several times)."""
    d = tmp_path_factory.mktemp("sim")
    log = d / "log.csv"
    run_cli(hal_sim, "simulate", "--scenario", "paper", "--hours", "2", "--seed", "3", "--out", str(log))
    return log


def test_simulate_equals_cli_log(sim_log):
    t, z, truth = read_log(sim_log)
    py = imu_ident.simulate("paper", hours=2, seed=3)
    np.testing.assert_array_equal(py["t"], t)
    np.testing.assert_array_equal(py["z"], z)
    for k in truth:
        np.testing.assert_array_equal(py["truth"][k], truth[k])


def test_adev_and_identify_equal_cli(tmp_path, hal_sim):
    # A gyro-like series: white noise plus a random walk (seeded), at 100 Hz.
    rng = np.random.default_rng(7)
    n, rate = 30000, 100.0
    y = 1e-3 * rng.standard_normal(n) + np.cumsum(1e-5 * rng.standard_normal(n))
    series = tmp_path / "series.csv"
    with open(series, "w") as f:
        f.write("gyro_x\n")
        f.writelines(f"{float(v)!r}\n" for v in y)  # repr round-trips exactly
    out = tmp_path / "ident"
    run_cli(hal_sim, "identify", "--series", str(series), "--column", "gyro_x", "--rate", "100",
            "--sensor", "gyro", "--quiet", "--out", str(out))

    cli = read_csv(out / "adev.csv")
    py = imu_ident.adev(y, rate)
    assert len(py["tau"]) == len(cli["tau"]) > 5
    for k in ("tau", "adev", "ci_lo", "ci_hi"):
        np.testing.assert_allclose(py[k], cli[k], rtol=RTOL, atol=0, err_msg=k)
    # Octave grid: tau = m / rate with m = 1, 2, 4, ...
    np.testing.assert_allclose(py["tau"], py["m"] / rate, rtol=RTOL)
    assert np.all(py["ci_lo"] < py["adev"]) and np.all(py["adev"] < py["ci_hi"])

    summary = json.loads((out / "summary.json").read_text())
    ident = imu_ident.identify(y, rate, "gyro", column="gyro_x")
    assert [c["label"] for c in ident["components"]] == [c["label"] for c in summary["components"]]
    assert ident["components"], "the white + random-walk series must select some component"
    for a, b in zip(ident["components"], summary["components"]):
        assert a["amplitude"] == pytest.approx(b["amplitude"], rel=RTOL)
    assert ident["bic"] == pytest.approx(summary["bic"], rel=RTOL)
    assert ident["model_toml"] == (out / "model.toml").read_text()
    # The identified model is a valid model for the replay.
    assert "dt" in imu_ident.model_toml(ident["model_toml"])


@pytest.mark.parametrize("adapt", [False, True])
def test_replay_equals_cli_run(tmp_path, hal_sim, root, sim_log, adapt):
    model = root / "hal-sim" / "scenarios" / "paper.toml"
    out = tmp_path / "run"
    args = ["run", "--log", str(sim_log), "--model", str(model), "--out", str(out)]
    run_cli(hal_sim, *args, *(["--adapt"] if adapt else []))

    t, z, truth = read_log(sim_log)
    py = imu_ident.replay(t, z, model, adapt=adapt, truth=truth)
    cli = read_csv(out / "estimates.csv")
    assert set(py["estimates"]) == set(cli)
    for k, col in cli.items():
        np.testing.assert_array_equal(py["estimates"][k], col, err_msg=k)

    cli_params = read_csv(out / "params.csv")
    for k, col in cli_params.items():
        if isinstance(col, list):
            assert list(py["params"][k]) == col, k
        else:
            np.testing.assert_array_equal(py["params"][k], col, err_msg=k)

    summary = json.loads((out / "summary.json").read_text())
    assert py["summary"] == summary
    if adapt:
        # Otherwise the adaptive comparison would only repeat the fixed one.
        assert summary["parameter_updates"] > 0
        assert "identified_model" in py["summary"]
    # The model as TOML text gives the same run as the path.
    same = imu_ident.replay(t, z, model.read_text(), adapt=adapt)
    np.testing.assert_array_equal(same["estimates"]["dv_hat"], py["estimates"]["dv_hat"])


def test_diagnose_equals_cli(tmp_path, hal_sim, root, sim_log):
    model = root / "hal-sim" / "scenarios" / "paper.toml"
    out = tmp_path / "diag"
    run_cli(hal_sim, "diagnose", "--log", str(sim_log), "--model", str(model), "--out", str(out))
    cli = json.loads((out / "diagnosis.json").read_text())
    t, z, _ = read_log(sim_log)
    py = imu_ident.diagnose(t, z, str(model))
    assert py["verdict"] in ("adequate", "missing-effect", "wrong-kind")
    suggested = py.pop("suggested_model_toml")
    assert suggested == (out / "suggested-model.toml").read_text()
    assert py == cli


def test_errors_name_the_problem():
    t = np.arange(1.0, 11.0)
    with pytest.raises(ValueError, match="same length"):
        imu_ident.replay(t, t[:5], imu_ident.scenario_toml("paper"))
    bad = imu_ident.scenario_toml("paper").replace("sigma_v", "sigma_vv")
    with pytest.raises(ValueError, match="sigma_vv"):
        imu_ident.replay(t, t, bad)
    with pytest.raises(FileNotFoundError):
        imu_ident.replay(t, t, "no-such-model.toml")
    with pytest.raises(ValueError, match="sensor"):
        imu_ident.identify(np.zeros(100), 1.0, "magnetometer")
    with pytest.raises(ValueError, match="1-D"):
        imu_ident.adev(np.zeros((10, 2)), 1.0)


def test_readme_example_runs_verbatim(root, monkeypatch, capsys):
    """The Python example of README.md, run as written from the repository root."""
    text = (root / "README.md").read_text()
    section = text[text.index("## Python"):]
    code = section[section.index("```python\n") + len("```python\n"):]
    code = code[: code.index("```")]
    assert len(code.strip().splitlines()) == 5, code
    monkeypatch.chdir(root)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2 and out[1] in ("adequate", "missing-effect", "wrong-kind"), out
