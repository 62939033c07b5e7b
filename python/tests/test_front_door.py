"""vbap.check, vbap.sim and vbap.batch against the `vbap` command: the same verdicts, the
same files byte for byte, the same errors."""

from __future__ import annotations

import json

import pytest

import vbap
from conftest import MISSIONS, cli, same_run

SHIPPED = sorted(p.name for p in MISSIONS.glob("*.toml"))


def test_every_shipped_mission_is_the_same_run_from_python_and_the_cli(tmp_path):
    assert len(SHIPPED) >= 9
    for name in SHIPPED:
        mission = MISSIONS / name
        # A fixed duration keeps the test short; the whole file is checked as the CLI does.
        checked = vbap.check(mission)
        out = cli("check", mission)
        assert out.returncode == 0, out.stderr
        assert f"valid ({checked['vehicles']} vehicles, {checked['ticks']} ticks" in out.stdout
        duration = {"duration": 3600.0} if "glider" in name or "ocean" in name else {}
        run = vbap.sim(mission, out=tmp_path / f"py-{name}", seed=5, **duration)
        args = ["sim", mission, "--seed", "5", "--out", tmp_path / f"cli-{name}", "--quiet"]
        if duration:
            args += ["--duration", "3600"]
        done = cli(*args)
        assert done.returncode == 0, done.stderr
        same_run(run.path, tmp_path / f"cli-{name}")
        cli_summary = json.loads((tmp_path / f"cli-{name}" / "summary.json").read_text())
        assert run.summary["verdict"] == cli_summary["verdict"], name


def test_sets_are_the_cli_sets(tmp_path):
    mission = MISSIONS / "paper.toml"
    sets = {"links.loss": 0.1, "links.delay": 0.2, "control.law": "robust", "mission.duration": 30}
    run = vbap.sim(mission, set=sets, out=tmp_path / "py")
    args = ["sim", mission, "--out", tmp_path / "cli", "--quiet"]
    for key, value in sets.items():
        args += ["--set", f"{key}={vbap.toml_value(value)}"]
    assert cli(*args).returncode == 0
    same_run(run.path, tmp_path / "cli")
    assert run.mission["links"]["loss"] == 0.1


@pytest.mark.parametrize(
    "sets, key",
    [
        ({"links.loss": 2}, "links.loss"),
        ({"vehicles.count": 0}, "vehicles.count"),
        ({"mission.start": "tomorrow"}, "mission.start"),
        ({"no.such_key": 1}, "no.such_key"),
    ],
)
def test_bad_input_raises_the_cli_message_naming_the_key_and_writes_nothing(tmp_path, sets, key):
    mission = MISSIONS / "glider.toml"
    out = tmp_path / "out"
    with pytest.raises(vbap.InvalidInput) as err:
        vbap.sim(mission, set=sets, out=out)
    assert isinstance(err.value, ValueError)
    assert key in str(err.value)
    assert not out.exists()
    args = ["sim", mission, "--out", out, "--quiet"]
    for k, v in sets.items():
        args += ["--set", f"{k}={vbap.toml_value(v)}"]
    done = cli(*args)
    assert done.returncode == 2
    assert f"vbap: {err.value}" in done.stderr
    with pytest.raises(vbap.InvalidInput, match=key.replace(".", r"\.")):
        vbap.check(mission, set=sets)


def test_a_run_directory_that_holds_a_run_is_refused(tmp_path):
    mission = MISSIONS / "paper.toml"
    vbap.sim(mission, duration=1.0, out=tmp_path / "r")
    before = (tmp_path / "r" / "summary.json").read_bytes()
    with pytest.raises(vbap.InvalidInput, match="already holds a run"):
        vbap.sim(mission, duration=1.0, out=tmp_path / "r")
    assert (tmp_path / "r" / "summary.json").read_bytes() == before


def test_a_batch_from_python_is_the_cli_batch(tmp_path):
    mission = MISSIONS / "paper.toml"
    kwargs = dict(seeds=2, sweep={"links.loss": [0.0, 0.2]}, set={"mission.duration": 20.0})
    b = vbap.batch(mission, jobs=2, out=tmp_path / "py", **kwargs)
    done = cli(
        "batch", mission, "--seeds", "2", "--sweep", "links.loss=0.0,0.2", "--set",
        "mission.duration=20.0", "--in-process", "--jobs", "2", "--quiet", "--out", tmp_path / "cli",
    )
    assert done.returncode in (0, 1), done.stderr
    assert b.passed == (done.returncode == 0)
    cli_table = __import__("pandas").read_csv(tmp_path / "cli" / "batch.csv")
    assert len(b.table) == 4
    wall = [c for c in b.table.columns if "wall" in c]
    assert b.table.drop(columns=wall).equals(cli_table.drop(columns=wall))
    runs = b.runs()
    assert len(runs) == 4
    for run in runs:
        same_run(run.path, tmp_path / "cli" / run.path.relative_to(b.path))
    assert b.summary["runs"] == 4


def test_run_tables_are_dataframes(tmp_path):
    run = vbap.sim(MISSIONS / "glider_surfacing.toml", duration=7200.0, out=tmp_path / "r")
    n, ticks = 6, 720
    assert len(run.vehicles) == n * ticks
    assert list(run.vehicles.columns[:5]) == ["t", "k", "id", "x", "y"]
    assert len(run.body) == ticks and len(run.truth) == ticks
    assert set(run.formation["contact"]) <= {
        "contact", "surfaced", "submerged", "link_down", "dead", "rejoining"
    }
    assert {"t", "k", "kind"} <= set(run.events.columns)
    inputs = run.planner_inputs
    assert inputs[inputs["k"] == 0]["measurement"].isna().all(), "NaN read as NaN"
    with pytest.raises(vbap.InvalidInput, match="not a run directory"):
        vbap.Run(tmp_path)


def test_the_message_records_of_a_multi_process_run_are_one_table(tmp_path):
    mission = MISSIONS / "paper.toml"
    name = f"pyrecords{__import__('os').getpid()}"
    done = cli(
        "run", mission, "--duration", "5", "--set", f'mission.name="{name}"', "--quiet",
        "--out", tmp_path / "run",
    )
    assert done.returncode == 0, done.stderr
    run = vbap.Run(tmp_path / "run")
    m = run.messages
    assert {"coordinator", "field_server", "vehicle_agent_0"} <= set(m["process"])
    state = m[(m["hop"] == "state") & (m["event"] == "recv")]
    assert len(state) > 0
    assert (state["recv_ns"] >= state["sent_ns"]).all(), "one host clock"
    assert vbap.sim(mission, duration=1.0, out=tmp_path / "sim").messages.empty
