"""`SweepTable`: the tidy result of a sweep (one row per collision), and its CSV form.

A leaf of the sweep modules (`store` and `sweep` import it; it imports only
`_batched.results`), so that the row stores can read and write tables without importing the sweep.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._batched.results import FAILED

TEXT_COLUMNS = ("status", "message")
INTEGER_COLUMNS = ("steps", "result", "retries", "balance_warning")  # balance_warning: 0/1
# A graded beam's profile (`CollisionParams.thickness_profile`): one float column per segment,
# thickness_profile_0 (at O) ... so that CSV, Parquet and xarray get 1-D columns
PROFILE = "thickness_profile"


def profile_names(segments: int) -> list[str]:
    """The columns of a profile of `segments` values, O to E."""
    return [f"{PROFILE}_{k}" for k in range(segments)]


@dataclasses.dataclass
class SweepTable:
    """One row per collision: every input (`INPUTS`) and every output (`OUTPUTS`) as columns.

    `columns` maps a name to a numpy array (float64; ``steps``, ``result`` and ``retries``
    int64; ``status`` and ``message`` str). `grid` holds the axes when the sweep was a full
    grid (rows in C order: the last axis varies fastest), else None. `wall_time_s` is the
    whole sweep's. `computed`, for a sweep that wrote its rows to a file, marks the rows
    this call computed (the others were read back from the file by ``resume=True``); None
    otherwise. A sweep of graded beams also has ``thickness_profile_0`` ... (h_k/h_r of each
    beam segment, O to E; ``table["thickness_profile"]`` gives them as one (rows, segments)
    array) and ``beam_mass_ratio``. `timing`, for a sweep solved in this process by the queue
    engine, is its cost: ``workers``, ``slots``, ``segments`` (compiled calls),
    ``compactions``, ``compile_s``, ``run_s`` (compilation excluded) and ``steps`` (the
    Verlet steps of every attempt, reruns at a smaller step included); None otherwise (Dask
    tasks, shards, a sweep read back whole).
    """

    columns: dict[str, np.ndarray]
    grid: dict[str, np.ndarray] | None = None
    wall_time_s: float = float("nan")
    computed: np.ndarray | None = None
    timing: dict[str, Any] | None = None

    def __len__(self) -> int:
        return len(next(iter(self.columns.values())))

    def __getitem__(self, name: str) -> np.ndarray:
        if name == PROFILE and name not in self.columns:
            profile = self.profile
            if profile is not None:
                return profile
        return self.columns[name]

    @property
    def profile(self) -> np.ndarray | None:
        """A graded sweep's thickness profiles, (rows, segments); None without them."""
        names, k = [], 0
        while f"{PROFILE}_{k}" in self.columns:
            names.append(f"{PROFILE}_{k}")
            k += 1
        if not names:
            return None
        return np.stack([self.columns[n] for n in names], axis=1)

    def keys(self):
        return self.columns.keys()

    @property
    def failed(self) -> np.ndarray:
        """Rows that went non-finite, broke their energy balance or ran out of steps."""
        return np.isin(self.columns["result"], FAILED)

    def rows(self) -> list[dict[str, Any]]:
        """The table as a list of flat dicts of Python scalars (NaN kept: write JSON with
        `msfd_jax._collision.provenance.dumps`, which makes it null)."""
        names = list(self.columns)
        return [{k: self.columns[k][i].item() for k in names} for i in range(len(self))]

    def to_csv(self, path: str | Path) -> Path:
        """Write a CSV with a header row; floats are written exactly (``repr``), NaN as an
        empty field (pandas and `read_csv` read it back as NaN)."""
        path = Path(path)
        with path.open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(self.columns)
            writer.writerows(csv_rows(self.columns))
        return path

    @classmethod
    def read_csv(cls, path: str | Path) -> SweepTable:
        """Read a CSV written by `to_csv` (column types as `SweepTable` documents them)."""
        with Path(path).open(newline="") as stream:
            reader = csv.reader(stream)
            header = next(reader)
            data = list(zip(*reader, strict=True)) or [() for _ in header]
        return cls({k: column(k, v) for k, v in zip(header, data, strict=True)})

    def to_xarray(self):
        """An ``xarray.Dataset`` on the grid axes (needs the optional extra ``sweep``)."""
        if self.grid is None:
            raise ValueError("only a full grid (a dict of value lists) maps onto an xarray grid")
        import xarray as xr

        shape = tuple(len(v) for v in self.grid.values())
        dims = tuple(self.grid)
        data = {k: (dims, v.reshape(shape)) for k, v in self.columns.items() if k not in self.grid}
        return xr.Dataset(data, coords={k: list(v) for k, v in self.grid.items()})

    def to_netcdf(self, path: str | Path) -> Path:
        """Write the grid as NetCDF via xarray (engine h5netcdf if installed)."""
        path = Path(path)
        self.to_xarray().to_netcdf(path)
        return path


def csv_rows(columns: dict[str, np.ndarray]) -> Iterable[list]:
    """The rows of `columns` as CSV fields: floats as ``repr`` (read back exactly), NaN (no
    number: a setting not given, a failed run's output) as an empty field."""
    names = list(columns)
    n = len(columns[names[0]]) if names else 0
    for i in range(n):
        values = (columns[k][i].item() for k in names)
        yield [_field(v) for v in values]


def _field(value: Any) -> Any:
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return value


def _number(value: Any) -> float:
    """A float field of a CSV (text; empty for NaN, as `csv_rows` writes it) or of Parquet."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return math.nan
    return float(value)


def column(name: str, values: Sequence[Any]) -> np.ndarray:
    """A column of text (CSV) or values (Parquet) as the type `SweepTable` gives `name`."""
    if name in TEXT_COLUMNS:
        return np.asarray([str(v) for v in values], dtype=str)
    if name in INTEGER_COLUMNS:
        return np.asarray([int(v) for v in values], dtype=np.int64)
    return np.asarray([_number(v) for v in values], dtype=np.float64)
