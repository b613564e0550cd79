"""The results store: one SQLite database per output directory, one row per run.

Every finished run is written in its own transaction, so a process killed at any moment
leaves either the whole row or none of it (SQLite's journal rolls a torn write back). The
row's primary key is a hash of the run's full configuration, which is how a rerun knows what
is already done. Trajectories live in compressed ``.npz`` files beside the database, written
under a temporary name and renamed before the row that references them is committed.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import time
from contextlib import closing, contextmanager
from pathlib import Path
from typing import Any, Iterable, Iterator

from swarmnav.errors import StoreError

DB_NAME = "results.sqlite"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    key          TEXT PRIMARY KEY,   -- sha256 of the canonical run configuration
    experiment   TEXT NOT NULL,
    variant      TEXT NOT NULL,
    scenario     TEXT NOT NULL,
    method       TEXT NOT NULL,
    seed         INTEGER NOT NULL,
    n            INTEGER,
    steps        INTEGER NOT NULL,
    params       TEXT NOT NULL,      -- JSON: the variant's declared method parameters
    config       TEXT NOT NULL,      -- JSON: the canonical configuration that was hashed
    status       TEXT NOT NULL CHECK (status IN ('done', 'failed')),
    error        TEXT NOT NULL DEFAULT '',
    metrics      TEXT NOT NULL DEFAULT '{}',  -- JSON: every metric (floats)
    wall_time_s  REAL,
    version      TEXT NOT NULL,
    trajectory   TEXT NOT NULL DEFAULT '',    -- path relative to the store directory
    artifacts    TEXT NOT NULL DEFAULT '[]',  -- JSON list of extra files (e.g. an LLM transcript), relative paths
    finished_at  REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_by_variant ON runs (experiment, variant, seed);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


def config_key(config: dict[str, Any]) -> str:
    """sha256 of a configuration's canonical JSON (sorted keys, no whitespace)."""
    blob = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


class Store:
    """A results database in directory ``root`` (created if missing)."""

    def __init__(self, root: str | Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.path = self.root / DB_NAME
        with self._db() as db:
            db.executescript(_SCHEMA)
            cols = {r[1] for r in db.execute("PRAGMA table_info(runs)")}
            if "artifacts" not in cols:  # a store written before artifacts were kept
                db.execute("ALTER TABLE runs ADD COLUMN artifacts TEXT NOT NULL DEFAULT '[]'")

    def _connect(self) -> sqlite3.Connection:
        db = sqlite3.connect(self.path, timeout=60.0)
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=FULL")  # a committed row survives a crash of the machine too
        return db

    @contextmanager
    def _db(self, transaction: bool = False) -> Iterator[sqlite3.Connection]:
        """A connection, closed after use (one transaction if ``transaction``). A file that SQLite
        cannot use (random bytes, a truncated or damaged database, a lock held past the timeout,
        a directory in its place) raises :class:`StoreError` naming it: bad input, not a bug."""
        try:
            with closing(self._connect()) as db:
                if transaction:
                    with db:
                        yield db
                else:
                    yield db
        except (sqlite3.IntegrityError, sqlite3.ProgrammingError, sqlite3.InterfaceError):
            raise  # our own SQL or rows are wrong: a bug, keep the traceback
        except sqlite3.DatabaseError as e:  # OperationalError too: locked, unable to open, disk I/O
            raise StoreError(f"{self.path}: not a usable results store (SQLite: {e})") from None

    # ------------------------------------------------------------------ writing
    def put(self, row: dict[str, Any]) -> None:
        """Insert or replace one run row in its own transaction."""
        self.put_many([row])

    def put_many(self, rows: Iterable[dict[str, Any]]) -> None:
        """Insert or replace rows, all in one transaction (all or none of them land)."""
        encoded = (_encode(r) for r in rows)
        values = [[e.get(c) for c in _COLUMNS] for e in encoded]
        with self._db(transaction=True) as db:
            db.executemany(f"INSERT OR REPLACE INTO runs ({', '.join(_COLUMNS)}) "
                           f"VALUES ({', '.join('?' * len(_COLUMNS))})", values)

    def set_meta(self, key: str, value: Any) -> None:
        with self._db(transaction=True) as db:
            db.execute("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)", (key, json.dumps(value)))

    # ------------------------------------------------------------------ reading
    def meta(self, key: str, default: Any = None) -> Any:
        with self._db() as db:
            r = db.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        try:
            return json.loads(r[0]) if r else default
        except json.JSONDecodeError:
            raise StoreError(f"{self.path}: not a usable results store (meta '{key}' is not JSON)") from None

    def meta_keys(self) -> list[str]:
        with self._db() as db:
            return [k for (k,) in db.execute("SELECT key FROM meta ORDER BY key")]

    def done_keys(self) -> set[str]:
        with self._db() as db:
            return {k for (k,) in db.execute("SELECT key FROM runs WHERE status = 'done'")}

    def rows(self, keys: Iterable[str] | None = None, experiment: str | None = None) -> list[dict[str, Any]]:
        """Rows as dicts with ``metrics``/``params``/``config`` decoded; all rows if no filter."""
        q, args = "SELECT * FROM runs", []
        if experiment is not None:
            q, args = q + " WHERE experiment = ?", [experiment]
        with self._db() as db:
            db.row_factory = sqlite3.Row
            found = [dict(r) for r in db.execute(q, args)]
        if keys is not None:
            wanted = {k: i for i, k in enumerate(keys)}
            found = sorted((r for r in found if r["key"] in wanted), key=lambda r: wanted[r["key"]])
        for r in found:
            for k in ("metrics", "params", "config"):
                r[k] = json.loads(r[k]) if r[k] else {}
            r["artifacts"] = json.loads(r.get("artifacts") or "[]")
        return found

    def count(self) -> dict[str, int]:
        with self._db() as db:
            return dict(db.execute("SELECT status, COUNT(*) FROM runs GROUP BY status").fetchall())


_COLUMNS = ["key", "experiment", "variant", "scenario", "method", "seed", "n", "steps", "params", "config",
            "status", "error", "metrics", "wall_time_s", "version", "trajectory", "artifacts", "finished_at"]


def _encode(row: dict[str, Any]) -> dict[str, Any]:
    values = dict(row)
    values["artifacts"] = json.dumps(values.get("artifacts") or [])
    for k in ("params", "config", "metrics"):
        if not isinstance(values.get(k, ""), str):
            values[k] = json.dumps(values[k], sort_keys=True, default=_json_default)
    values.setdefault("finished_at", time.time())
    return values


def _json_default(o: Any) -> Any:
    try:
        return float(o)
    except (TypeError, ValueError):
        return str(o)
