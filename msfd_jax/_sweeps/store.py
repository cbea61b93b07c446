"""Row stores: a sweep's rows written as they finish, read back to resume a killed sweep.

Two formats, chosen by the path's suffix:

- ``.csv``: one append-only file. The header and the rows kept from an earlier run are
  written first (atomically: a temporary file renamed over the path); each finished group of
  collisions is then appended and flushed to disk (``fsync``), so a killed sweep leaves every
  finished group and at most a half-written last line, which `CsvStore.finished` drops.
- ``.parquet``: a directory of part files (pyarrow), one per finished group, each written to a
  temporary name and renamed, so a part is either whole or absent.

When the sweep ends, the store is rewritten as one table in the sweep's order (CSV: the file;
Parquet: ``table.parquet`` in the directory, the parts removed), equal to `SweepTable.to_csv`.
Beside the rows, ``meta.json`` (CSV: ``PATH.meta.json``) records the mesh, settings and
smoothing, and a resume with other numerics is refused: its rows would not belong together.
"""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

import numpy as np

from .._collision.provenance import dumps
from .table import column, csv_rows


def open_store(path: str | Path):
    """The store for `path` by its suffix (``.csv`` or ``.parquet``); ValueError otherwise."""
    path = Path(path)
    if path.suffix == ".csv":
        return CsvStore(path)
    if path.suffix == ".parquet":
        return ParquetStore(path)
    raise ValueError(f"output {str(path)!r} must end in .csv or .parquet")


def match_rows(
    columns: dict[str, np.ndarray], finished: dict[str, np.ndarray], inputs, path
) -> np.ndarray:
    """For each collision of `columns`, the index of its row in `finished`, or -1.

    A row matches a collision when all its `inputs` are equal (exact floats: the CSV writes
    them with ``repr``, Parquet as float64). Refused (ValueError) when `finished` lacks a
    column, or holds a row that is no collision of the sweep: a resume continues one sweep.
    """
    if not finished:
        return np.full(len(columns[inputs[0]]), -1)
    lacking = sorted(set(inputs) - set(finished))
    if lacking:
        raise ValueError(f"resume: {path} has no column {', '.join(lacking)}; not a sweep table")
    index = {
        key: i for i, key in enumerate(zip(*(finished[k].tolist() for k in inputs), strict=True))
    }
    wanted = list(zip(*(columns[k].tolist() for k in inputs), strict=True))
    found = np.asarray([index.get(key, -1) for key in wanted], dtype=np.int64)
    foreign = len(index) - len(set(found[found >= 0].tolist()))
    if foreign:
        raise ValueError(
            f"resume: {path} holds {foreign} rows that are no collision of this sweep; "
            "resume the same sweep, or write to a new path"
        )
    return found


class _Store:
    path: Path
    meta_path: Path

    def exists(self) -> bool:
        raise NotImplementedError

    def check_meta(self, meta: dict) -> None:
        """Refuse to resume rows computed with other numerics (no record: nothing to check)."""
        if not self.meta_path.exists():
            return
        old = json.loads(self.meta_path.read_text())
        meta = json.loads(dumps(meta))  # as written: tuples as lists, NaN as null
        differ = sorted(k for k in {*old, *meta} if old.get(k) != meta.get(k))
        if differ:
            raise ValueError(
                f"resume: the rows in {self.path} were computed with another "
                f"{', '.join(differ)} (see {self.meta_path}); resume with the same numerics "
                "or write to a new path"
            )

    def write_meta(self, meta: dict) -> None:
        _atomic_write(self.meta_path, dumps(meta, indent=1, sort_keys=True) + "\n")


class CsvStore(_Store):
    def __init__(self, path: Path):
        self.path, self.meta_path = path, path.with_name(path.name + ".meta.json")
        self.stream = None
        self.names: list[str] = []

    def exists(self) -> bool:
        return self.path.exists()

    def finished(self) -> dict[str, np.ndarray]:
        """The complete rows in the file; a half-written last line (a kill) is dropped."""
        with self.path.open(newline="") as stream:
            text = stream.read()
        if not text.endswith("\n"):  # killed mid-write: the tail after the last newline
            text = text[: text.rfind("\n") + 1]
        rows = _complete_rows(text)
        if not rows:
            return {}
        header, body = rows[0], [r for r in rows[1:] if len(r) == len(rows[0])]
        data = list(zip(*body, strict=True)) or [() for _ in header]
        return {k: column(k, v) for k, v in zip(header, data, strict=True)}

    def start(self, names: list[str], kept: dict[str, np.ndarray] | None) -> None:
        """Write the header and the `kept` rows (atomically), then open for appending."""
        self.names = list(names)
        buffer = io.StringIO(newline="")
        writer = csv.writer(buffer)
        writer.writerow(self.names)
        if kept:
            writer.writerows(csv_rows({k: kept[k] for k in self.names}))
        _atomic_write(self.path, buffer.getvalue())
        self.stream = self.path.open("a", newline="")

    def append(self, columns: dict[str, np.ndarray]) -> None:
        csv.writer(self.stream).writerows(csv_rows({k: columns[k] for k in self.names}))
        self.stream.flush()
        os.fsync(self.stream.fileno())

    def close(self) -> None:
        if self.stream is not None:
            self.stream.close()
            self.stream = None

    def finish(self, columns: dict[str, np.ndarray]) -> None:
        """Rewrite the file as the whole table, in the sweep's order."""
        self.close()
        buffer = io.StringIO(newline="")
        writer = csv.writer(buffer)
        writer.writerow(list(columns))
        writer.writerows(csv_rows(columns))
        _atomic_write(self.path, buffer.getvalue())


class ParquetStore(_Store):
    def __init__(self, path: Path):
        self.path, self.meta_path = path, path / "meta.json"
        self.names: list[str] = []
        self.serial = 0

    def exists(self) -> bool:
        return self.path.exists() and any(self.path.glob("*.parquet"))

    def finished(self) -> dict[str, np.ndarray]:
        import pyarrow as pa
        import pyarrow.parquet as pq

        parts = sorted(self.path.glob("*.parquet"))
        if not parts:
            return {}
        table = pa.concat_tables([pq.read_table(p) for p in parts])
        return {k: column(k, table.column(k).to_pylist()) for k in table.column_names}

    def start(self, names: list[str], kept: dict[str, np.ndarray] | None) -> None:
        self.names = list(names)
        self.path.mkdir(parents=True, exist_ok=True)
        old = sorted(self.path.glob("*.parquet"))
        if kept and len(next(iter(kept.values()))):
            self._write(self.path / "kept.parquet", kept)
        for part in old:  # the kept rows hold everything these had that the sweep needs
            if part.name != "kept.parquet":
                part.unlink()
        self.serial = 0

    def append(self, columns: dict[str, np.ndarray]) -> None:
        self.serial += 1
        self._write(self.path / f"part-{os.getpid()}-{self.serial:06d}.parquet", columns)

    def close(self) -> None:
        pass

    def finish(self, columns: dict[str, np.ndarray]) -> None:
        old = [p for p in self.path.glob("*.parquet") if p.name != "table.parquet"]
        self._write(self.path / "table.parquet", columns)
        for part in old:
            part.unlink()

    def _write(self, path: Path, columns: dict[str, np.ndarray]) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        names = self.names or list(columns)
        table = pa.table({k: np.asarray(columns[k]) for k in names})
        temporary = path.with_name(f".{path.name}.tmp")
        pq.write_table(table, temporary)
        os.replace(temporary, path)


def _complete_rows(text: str) -> list[list[str]]:
    """CSV rows of `text`; a row cut inside a quoted field (a kill) ends the list."""
    rows = []
    try:
        for row in csv.reader(io.StringIO(text, newline="")):
            rows.append(row)
    except csv.Error:
        pass
    return rows


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    with temporary.open("w", newline="") as stream:
        stream.write(text)
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary, path)
