"""A run directory and a batch directory read as Python objects (pandas, xarray)."""

from __future__ import annotations

import json
import os
import tempfile
from functools import cached_property
from pathlib import Path
from typing import Union

import pandas as pd

from ._native import InvalidInput

PathLike = Union[str, os.PathLike]


class Run:
    """A run directory of ``vbap sim`` or ``vbap run``.

    Tables (pandas DataFrames, read once): :attr:`vehicles`, :attr:`body`,
    :attr:`truth`, :attr:`formation`, :attr:`planner_inputs` (CSV, ``NaN`` and empty
    fields as NaN) and :attr:`events` (``events.jsonl``); :attr:`summary` (``summary.json``)
    and :attr:`mission` (the resolved ``mission.toml``) as dicts; :meth:`to_xarray` and
    :meth:`to_netcdf` the CF-1.8 trajectories of ``vbap export``.
    """

    def __init__(self, path: PathLike):
        self.path = Path(path)
        if not (self.path / "mission.toml").is_file():
            raise InvalidInput(f"{self.path}: not a run directory (no mission.toml)")

    def __repr__(self) -> str:
        return f"vbap.Run({str(self.path)!r})"

    def _csv(self, name: str) -> pd.DataFrame:
        file = self.path / name
        if not file.is_file():
            raise InvalidInput(f"{self.path}: no {name}")
        return pd.read_csv(file)

    @cached_property
    def summary(self) -> dict:
        """``summary.json``: the verdict and the run's figures."""
        return json.loads((self.path / "summary.json").read_text())

    @cached_property
    def mission(self) -> dict:
        """The resolved mission (every key, defaults filled in)."""
        import tomllib

        return tomllib.loads((self.path / "mission.toml").read_text())

    @cached_property
    def vehicles(self) -> pd.DataFrame:
        """``vehicles.csv``: one row per vehicle and tick (true position, velocity, reading)."""
        return self._csv("vehicles.csv")

    @cached_property
    def body(self) -> pd.DataFrame:
        """``body.csv``: the virtual body per tick (centre, scale, gradient estimate, V)."""
        return self._csv("body.csv")

    @cached_property
    def truth(self) -> pd.DataFrame:
        """``truth.csv``: the true figures per tick (V/V_U, nearest pair, slot error)."""
        return self._csv("truth.csv")

    @cached_property
    def formation(self) -> pd.DataFrame:
        """``formation.csv``: each vehicle's true formation and contact per tick."""
        return self._csv("formation.csv")

    @cached_property
    def planner_inputs(self) -> pd.DataFrame:
        """``planner_inputs.csv``: every argument of every planner step."""
        return self._csv("planner_inputs.csv")

    @cached_property
    def events(self) -> pd.DataFrame:
        """``events.jsonl``: one row per event (lost, rejoin, redesign, ...)."""
        file = self.path / "events.jsonl"
        rows = [json.loads(line) for line in file.read_text().splitlines() if line.strip()]
        return pd.DataFrame(rows)

    @cached_property
    def messages(self) -> pd.DataFrame:
        """The message records of a ``vbap run`` (``logs/*.msgs.csv``), every process's in
        one table: ``process`` (the file's name), then ``event`` (send, recv, held, drop),
        ``hop``, ``sender``, ``receiver``, ``tick``, ``seq``, ``sent_ns``, ``recv_ns``,
        ``injected_ns``, ``reason``, ``bytes``; e.g. the state hop's transport latency is
        ``recv_ns - sent_ns - injected_ns`` of its ``recv`` rows. Empty for a ``vbap sim``
        run (no processes, no records)."""
        frames = []
        for file in sorted((self.path / "logs").glob("*.msgs.csv")):
            frame = pd.read_csv(file, dtype={"sent_ns": "Int64", "recv_ns": "Int64", "injected_ns": "Int64"})
            frame.insert(0, "process", file.name.removesuffix(".msgs.csv"))
            frames.append(frame)
        if not frames:
            return pd.DataFrame()
        return pd.concat(frames, ignore_index=True)

    def to_netcdf(self, path: PathLike) -> Path:
        """Writes the run as one CF-1.8 trajectory NetCDF file (``vbap export --netcdf``)."""
        from . import export_netcdf

        return export_netcdf(self.path, path)

    #: The tables :meth:`to_xarray` turns into Datasets, with their index columns.
    TABLE_INDEX = {
        "vehicles": ["k", "id"],
        "formation": ["k", "id"],
        "body": ["k"],
        "truth": ["k"],
        "planner_inputs": ["k", "role", "id"],
    }

    def to_xarray(self, table: str | None = None):
        """The run as an ``xarray.Dataset``.

        Without ``table``: the CF trajectories of :meth:`to_netcdf` (dimensions
        ``trajectory``: the vehicles then the body, ``obs``: the ticks), loaded into
        memory. With ``table`` (``"vehicles"``, ``"formation"``, ``"body"``, ``"truth"``,
        ``"planner_inputs"``): that table indexed by tick ``k`` (and vehicle ``id``), each
        other column a variable; ``t`` (s) a coordinate along ``k``.
        """
        import xarray as xr

        if table is not None:
            if table not in self.TABLE_INDEX:
                raise InvalidInput(
                    f"{table!r}: not a table of a run ({', '.join(self.TABLE_INDEX)})"
                )
            frame = getattr(self, table)
            ds = frame.set_index(self.TABLE_INDEX[table]).to_xarray()
            if "t" in ds:
                # One time per tick: a coordinate along k.
                t = frame.groupby("k")["t"].first()
                ds = ds.drop_vars("t").assign_coords(t=("k", t.reindex(ds["k"].values).values))
            return ds
        with tempfile.TemporaryDirectory() as tmp:
            file = Path(tmp) / "run.nc"
            self.to_netcdf(file)
            with xr.open_dataset(file) as ds:
                return ds.load()


class Batch:
    """A batch directory of ``vbap batch``: :attr:`table` (``batch.csv``, one row per
    run), :attr:`summary` (``batch.json``, the aggregate and the criteria), :attr:`passed`
    and the runs themselves (:meth:`runs`)."""

    def __init__(self, path: PathLike, passed: bool):
        self.path = Path(path)
        self.passed = passed

    def __repr__(self) -> str:
        return f"vbap.Batch({str(self.path)!r}, passed={self.passed})"

    @cached_property
    def table(self) -> pd.DataFrame:
        return pd.read_csv(self.path / "batch.csv")

    @cached_property
    def summary(self) -> dict:
        return json.loads((self.path / "batch.json").read_text())

    def runs(self) -> list[Run]:
        """Every run directory of the batch, in the table's order."""
        return [Run(p.parent) for p in sorted(self.path.rglob("mission.toml"))]
