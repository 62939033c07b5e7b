"""vbap from Python: virtual bodies and artificial potentials (Ögren, Fiorelli and
Leonard, IEEE TAC 2004), a fleet of vehicles climbing the gradient of a noisy field.

The functions are the ``vbap`` commands of the same names, on the same Rust crates (the
extension module ``vbap._native``): the same validation, the same run directories, the
same verdicts, byte for byte.

>>> import vbap
>>> vbap.check("deploy/missions/glider.toml")["vehicles"]
4
>>> run = vbap.sim("deploy/missions/glider.toml", seed=3, set={"links.loss": 0.2})
>>> run.summary["verdict"], run.vehicles.head()

Mission keys are set with ``set={"links.loss": 0.2, "control.law": "paper"}`` (as
``--set links.loss=0.2``); bad input raises :class:`InvalidInput` (a ``ValueError``) with
the message ``vbap`` prints before its exit code 2, naming the key.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional, Union

from . import _native
from ._native import InvalidInput
from .run import Batch, Run

__all__ = [
    "InvalidInput",
    "Batch",
    "Run",
    "batch",
    "check",
    "export_netcdf",
    "sim",
    "toml_value",
]
__version__ = _native.__version__

PathLike = Union[str, os.PathLike]


def toml_value(value: Any) -> str:
    """``value`` as the TOML text of ``--set KEY=VALUE`` (bool, int, float, str, list)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value) if isinstance(value, int) else _float(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise InvalidInput(f"{value!r}: a mission key's value is a bool, number, string or list")


def _float(x: float) -> str:
    if x != x:
        return "nan"
    if x in (float("inf"), float("-inf")):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def _sets(values: Optional[Mapping[str, Any]]) -> list[str]:
    return [f"{key}={toml_value(v)}" for key, v in (values or {}).items()]


def _sweep(values: Optional[Mapping[str, Iterable[Any]]]) -> list[str]:
    return [
        f"{key}=" + ",".join(toml_value(v) for v in vs) for key, vs in (values or {}).items()
    ]


def check(path: PathLike, set: Optional[Mapping[str, Any]] = None) -> dict:
    """Validates a mission file (``vbap check``): ``{"mission", "vehicles", "ticks",
    "dim", "warnings", "notes"}``; raises :class:`InvalidInput` naming what is wrong."""
    return json.loads(_native.check(os.fspath(path), _sets(set)))


def sim(
    path: PathLike,
    *,
    seed: Optional[int] = None,
    vehicles: Optional[int] = None,
    duration: Optional[float] = None,
    set: Optional[Mapping[str, Any]] = None,
    out: Optional[PathLike] = None,
) -> Run:
    """Runs a mission in this process (``vbap sim``) into ``out`` (default
    ``runs/<mission>-<UTC time>/``); returns the :class:`Run`. Ctrl-C stops it after the
    tick in progress (its files are written) and raises ``KeyboardInterrupt``."""
    root, _summary = _native.sim(
        os.fspath(path),
        _sets(set),
        seed,
        vehicles,
        duration,
        None if out is None else os.fspath(out),
    )
    return Run(root)


def batch(
    path: PathLike,
    *,
    seeds: int,
    sweep: Optional[Mapping[str, Iterable[Any]]] = None,
    set: Optional[Mapping[str, Any]] = None,
    jobs: int = 1,
    out: Optional[PathLike] = None,
) -> Batch:
    """Runs a mission for ``seeds`` seeds over the grid of ``sweep`` (``vbap batch
    --in-process``), ``jobs`` at a time; returns the :class:`Batch` (its table, its
    aggregate and whether its criteria passed)."""
    root, code = _native.batch(
        os.fspath(path),
        seeds,
        _sets(set),
        _sweep(sweep),
        jobs,
        None if out is None else os.fspath(out),
    )
    return Batch(root, passed=(code == 0))


def export_netcdf(run_dir: PathLike, path: PathLike) -> Path:
    """Writes a run directory as one CF-1.8 trajectory NetCDF file (``vbap export
    --netcdf``); returns its path."""
    _native.export_netcdf(os.fspath(run_dir), os.fspath(path))
    return Path(path)
