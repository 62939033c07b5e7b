"""`vbap export --netcdf` and vbap.Run.to_xarray: CF-1.8 trajectories that open in xarray,
hold the run's numbers and pass the IOOS compliance checker's CF test without an error."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

import vbap
from conftest import MISSIONS, cli


def compliance_errors(nc: Path) -> list:
    """The failed checks of `compliance-checker --test cf:1.8` (any priority)."""
    out = nc.with_suffix(".json")
    checker = Path(sys.executable).with_name("compliance-checker")
    subprocess.run(
        [str(checker), "--test", "cf:1.8", "--format", "json", "--output", str(out), str(nc)],
        check=False,
        capture_output=True,
    )
    report = json.loads(out.read_text())["cf:1.8"]
    failed = []
    for level in ("high_priorities", "medium_priorities", "low_priorities"):
        for check in report.get(level, []):
            got, of = check["value"]
            if got < of:
                failed.append((level, check["name"], check["msgs"]))
    return failed


def test_a_glider_run_passes_the_cf_checker_and_opens_in_xarray(tmp_path):
    run = vbap.sim(
        MISSIONS / "glider_iridium.toml",
        duration=14400.0,
        set={"mission.start": "2026-08-01T00:00:00Z"},
        out=tmp_path / "run",
    )
    nc = run.to_netcdf(tmp_path / "run.nc")
    assert compliance_errors(nc) == []
    # The CLI writes the same bytes.
    assert cli("export", run.path, "--netcdf", tmp_path / "cli.nc").returncode == 0
    assert (tmp_path / "cli.nc").read_bytes() == nc.read_bytes()

    ds = run.to_xarray()
    assert ds.attrs["featureType"] == "trajectory"
    assert ds.sizes["trajectory"] == 7 and ds.sizes["obs"] == 1440
    assert str(ds["time"].values[0, 0]).startswith("2026-08-01T00:00:00")
    v = run.vehicles
    for vid in range(6):
        rows = v[v["id"] == vid].sort_values("k")
        np.testing.assert_array_equal(ds["x"].values[vid, :], rows["x"].to_numpy())
    np.testing.assert_array_equal(ds["x"].values[6, :], run.body["rx"].to_numpy())
    np.testing.assert_array_equal(
        ds["V_true_over_VU"].values[6, :], run.truth["V_true_over_VU"].to_numpy()
    )
    assert np.isnan(ds["V_true_over_VU"].values[:6, :]).all(), "fill on the vehicles"


def test_a_geographic_and_a_diving_mission_pass_the_cf_checker(tmp_path):
    for name, extra in [("ocean_grid.toml", {"duration": 1200.0}), ("dive3d.toml", {"duration": 10.0})]:
        run = vbap.sim(MISSIONS / name, out=tmp_path / name, **extra)
        nc = run.to_netcdf(tmp_path / f"{name}.nc")
        assert compliance_errors(nc) == [], name
        ds = run.to_xarray()
        if name == "ocean_grid.toml":
            lon = ds["lon"].values
            assert 7.6 < np.nanmin(lon) and np.nanmax(lon) < 8.2
        else:
            assert "z" in ds


def test_each_table_is_a_dataset_indexed_by_tick_and_vehicle(tmp_path):
    run = vbap.sim(MISSIONS / "glider_surfacing.toml", duration=3600.0, out=tmp_path / "r")
    v = run.to_xarray("vehicles")
    assert dict(v.sizes) == {"k": 360, "id": 6}
    np.testing.assert_array_equal(v["t"].values, run.body["t"].to_numpy())
    rows = run.vehicles[run.vehicles["id"] == 4].sort_values("k")
    np.testing.assert_array_equal(v["x"].sel(id=4).values, rows["x"].to_numpy())
    body = run.to_xarray("body")
    assert dict(body.sizes) == {"k": 360}
    f = run.to_xarray("formation")
    assert set(np.unique(f["contact"].values)) <= {
        "contact", "surfaced", "submerged", "link_down", "dead", "rejoining"
    }
    try:
        run.to_xarray("nothing")
    except vbap.InvalidInput as e:
        assert "not a table" in str(e)
    else:
        raise AssertionError("an unknown table is refused")
