"""The record of one run, and its on-disk form (a run directory)."""

from __future__ import annotations

import json
import os
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import SwarmnavError


@dataclass(eq=False)
class RunResult:
    """Everything a run produced.

    Attributes:
        config: what reproduces the run: version, method, params, scene (as a dict), seed,
            steps, dt.
        positions: (K + 1, N, d) [m], d = the scene's dimension (2 or 3).
        velocities: (K + 1, N, d) [m/s].
        clearance: (K + 1, N) signed distance to the nearest obstacle [m] (+inf: none).
        labels: (K + 1, N) sub-swarm id of each agent.
        roles: (K + 1, N) uint8 role of each agent (0 follower, 1 subleader, 2 leader) when the
            method reports roles (``info["roles"]``); None otherwise, and then not saved.
        thrust_axis: (K + 1, N, 3) float32 body z axis (thrust direction) of each agent, a unit
            vector in world axes, when the run flew quadrotors (``vehicle=quadrotor``,
            docs/vehicle.md); always 3-D (on a 2-D scene: the scene's x, y and the vertical);
            None for the point vehicle, and then not saved.
        events: structural events, dicts with ``step``, ``action``, ``source``, ``reason``.
        metrics: scalar metrics (floats).
        wall_time: seconds spent in the rollout loop [s].
        artifacts: extra files of the run, file name -> content, from the method's optional
            ``artifacts()`` hook (e.g. ``llm_transcript.jsonl``); written by ``save``.
        timings: wall-clock figures from the method's optional ``timings()`` hook (e.g.
            planning time per replan [ms]); not reproducible, so kept out of ``metrics``.
        plans: the trajectories the method committed, from its optional ``plans()`` hook
            (:class:`Plans`); None for a method without the hook or a run with ``plans=False``,
            and then not saved.
    """

    config: dict[str, Any]
    positions: np.ndarray
    velocities: np.ndarray
    clearance: np.ndarray
    labels: np.ndarray
    roles: np.ndarray | None = None
    thrust_axis: np.ndarray | None = None
    events: list[dict[str, Any]] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    wall_time: float = 0.0
    artifacts: dict[str, str | bytes] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    plans: Plans | None = None

    @property
    def n_subswarms(self) -> np.ndarray:
        """(K + 1,) number of distinct sub-swarms per step."""
        lab = np.sort(self.labels, axis=1)
        return 1 + np.count_nonzero(np.diff(lab, axis=1), axis=1)

    @property
    def min_clearance(self) -> np.ndarray:
        """(K + 1,) minimum clearance over agents per step [m]."""
        return self.clearance.min(axis=1)

    def save(self, out: str | Path) -> Path:
        """Write ``metrics.json``, ``trajectory.npz``, ``config.json``, ``events.jsonl`` and
        every artifact under its own name.

        Files are written to a temporary name and renamed, so a killed process never leaves a
        half-written file under the final name. A name that is taken by a directory, or a file
        that cannot be written, raises SwarmnavError naming it and leaves no temporary file.
        """
        d = Path(out)
        d.mkdir(parents=True, exist_ok=True)
        for name in self.artifacts:
            if Path(name).name != name or name.startswith(".") or name in RUN_FILES:
                raise SwarmnavError(f"artifact name must be a plain file name of its own, got {name!r}")
        for name in (*RUN_FILES, *self.artifacts):  # checked before anything is written
            if (d / name).exists() and not (d / name).is_file():
                raise SwarmnavError(f"cannot write {d / name}: a directory (or other non-file) is in the way")
        extra = {} if self.roles is None else {"roles": self.roles}  # a run without roles keeps its old file
        if self.thrust_axis is not None:  # and a point-mass run
            extra["thrust_axis"] = np.asarray(self.thrust_axis, dtype=np.float32)
        if self.plans is not None:  # likewise a run without plans
            extra.update({PLAN_PREFIX + k: v for k, v in self.plans.arrays().items()})
        _atomic(d / "trajectory.npz", lambda f: np.savez_compressed(
            f, positions=self.positions, velocities=self.velocities, clearance=self.clearance,
            labels=self.labels, **extra))
        _atomic(d / "events.jsonl", lambda f: f.write("".join(json.dumps(e) + "\n" for e in self.events).encode()))
        _atomic(d / "config.json", lambda f: f.write(json.dumps(self.config, indent=2).encode()))
        metrics = dict(self.metrics, wall_time_s=self.wall_time)
        _atomic(d / "metrics.json", lambda f: f.write(json.dumps(_jsonable(metrics), indent=2).encode()))
        for name, content in self.artifacts.items():
            data = content.encode() if isinstance(content, str) else bytes(content)
            _atomic(d / name, lambda f, data=data: f.write(data))
        return d

    @classmethod
    def load(cls, out: str | Path) -> RunResult:
        d = Path(out)
        try:
            config = json.loads((d / "config.json").read_text())
            metrics = json.loads((d / "metrics.json").read_text())
            with np.load(d / "trajectory.npz") as z:
                arrays = {k: z[k] for k in z.files}
        except FileNotFoundError as e:
            raise SwarmnavError(f"{d}: not a run directory (missing {Path(e.filename).name})") from None
        except (json.JSONDecodeError, ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as e:
            # a truncated or damaged trajectory.npz is bad input, not a bug: one line
            raise SwarmnavError(f"{d}: unreadable run directory: {e}") from None
        missing = [k for k in ("positions", "velocities", "clearance", "labels") if k not in arrays]
        if missing:
            raise SwarmnavError(f"{d}: trajectory.npz lacks {', '.join(missing)}")
        P = arrays["positions"]
        if P.ndim != 3 or P.shape[0] < 1 or P.shape[2] not in (2, 3) or arrays["velocities"].shape != P.shape \
                or arrays["clearance"].shape != P.shape[:2] or arrays["labels"].shape != P.shape[:2] \
                or arrays.get("roles", arrays["labels"]).shape != P.shape[:2] \
                or ("thrust_axis" in arrays and arrays["thrust_axis"].shape != (*P.shape[:2], 3)):
            raise SwarmnavError(f"{d}: trajectory.npz arrays disagree in shape (positions {P.shape}, velocities "
                                f"{arrays['velocities'].shape}, clearance {arrays['clearance'].shape}, labels "
                                f"{arrays['labels'].shape}"
                                + (f", thrust_axis {arrays['thrust_axis'].shape}" if "thrust_axis" in arrays else "")
                                + ")")
        stored = {k.removeprefix(PLAN_PREFIX): arrays.pop(k) for k in list(arrays) if k.startswith(PLAN_PREFIX)}
        plans = None  # a run directory without plan arrays: a method without the hook, or an older run
        if stored:
            try:
                plans = Plans.from_arrays(stored, n=P.shape[1], dim=P.shape[2])
            except ValueError as e:
                raise SwarmnavError(f"{d}: trajectory.npz has damaged plans: {e}") from None
        events = []
        ev = d / "events.jsonl"
        if ev.exists():
            events = [json.loads(line) for line in ev.read_text().splitlines() if line.strip()]
        wall = float(metrics.pop("wall_time_s", 0.0))
        return cls(config=config, events=events, metrics=metrics, wall_time=wall, plans=plans, **arrays)


@dataclass(frozen=True, slots=True, eq=False)
class Plans:
    """Every trajectory a method committed in a run, in commit order (the ``plans()`` hook,
    docs/methods/contract.md). Plan j was committed by robot ``robot[j]`` at control step
    ``step[j]`` and passes through ``points[offsets[j]:offsets[j + 1]]`` at run times
    ``times[offsets[j]:offsets[j + 1]]``.

    Attributes:
        step: (P,) int32 control step of each commit (non-decreasing).
        robot: (P,) int32 index of the robot that committed it.
        offsets: (P + 1,) int64, 0 first and M last, non-decreasing.
        points: (M, d) float32 sampled positions [m], d the run's dimension.
        times: (M,) float32 run time of each sample [s].
    """

    step: np.ndarray
    robot: np.ndarray
    offsets: np.ndarray
    points: np.ndarray
    times: np.ndarray

    def __len__(self) -> int:
        return len(self.step)

    @property
    def nbytes(self) -> int:
        """Bytes the five arrays take in memory (and, uncompressed, in ``trajectory.npz``)."""
        return sum(a.nbytes for a in self.arrays().values())

    def arrays(self) -> dict[str, np.ndarray]:
        return {"step": self.step, "robot": self.robot, "offsets": self.offsets, "points": self.points,
                "times": self.times}

    def trajectory(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Plan ``j``'s points (L, d) [m] and times (L,) [s]."""
        a, b = self.offsets[j], self.offsets[j + 1]
        return self.points[a:b], self.times[a:b]

    def latest(self, step: int, n: int) -> np.ndarray:
        """(n,) index of each robot's latest plan committed at or before ``step`` (-1: none yet)."""
        out = np.full(n, -1, dtype=np.int64)
        j = np.flatnonzero(self.step <= step)
        out[self.robot[j]] = j  # commit order: a later plan of a robot overwrites an earlier one
        return out

    @classmethod
    def from_arrays(cls, a: dict[str, Any], n: int, dim: int, lift: float | None = None) -> Plans:
        """Checked, typed plans from the hook's arrays (``lift``: the altitude [m] at which a
        planar method's 2-D points are placed in a 3-D run). Raises ValueError naming the fault."""
        missing = sorted({"step", "robot", "offsets", "points", "times"} - set(a))
        extra = sorted(set(a) - {"step", "robot", "offsets", "points", "times"})
        if missing or extra:
            raise ValueError(f"plans need step, robot, offsets, points and times (missing {missing}, unknown {extra})")
        step, robot, off = (_integers(a[k], t, k) for k, t in (("step", np.int32), ("robot", np.int32),
                                                                ("offsets", np.int64)))
        pts = np.asarray(a["points"], dtype=np.float32)
        times = np.asarray(a["times"], dtype=np.float32).reshape(-1)
        if lift is not None and pts.ndim == 2 and pts.shape[1] == 2 and dim == 3:
            pts = np.column_stack([pts, np.full(len(pts), lift, dtype=np.float32)])
        P = len(step)
        if len(robot) != P or len(off) != P + 1:
            raise ValueError(f"{P} steps, {len(robot)} robots and {len(off)} offsets (want {P + 1})")
        if pts.ndim != 2 or pts.shape[1] != dim or len(times) != len(pts):
            raise ValueError(f"points {pts.shape} and times {times.shape} must be (M, {dim}) and (M,)")
        if off[0] != 0 or off[-1] != len(pts) or np.any(np.diff(off) < 0):
            raise ValueError(f"offsets must rise from 0 to {len(pts)}")
        if P and (robot.min() < 0 or robot.max() >= n or step.min() < 0 or np.any(np.diff(step) < 0)):
            raise ValueError(f"robots must lie in 0..{n - 1} and steps rise from 0")
        if not (np.isfinite(pts).all() and np.isfinite(times).all()):
            raise ValueError("points and times must be finite")
        return cls(step, robot, off, pts, times)


#: Prefix of the plans' arrays in ``trajectory.npz`` (``plan_step``, ``plan_points``, ...).
PLAN_PREFIX = "plan_"


#: The files :meth:`RunResult.save` always writes (artifacts come on top, under their own names).
RUN_FILES = ("metrics.json", "trajectory.npz", "config.json", "events.jsonl")


def _integers(x: Any, dtype, name: str) -> np.ndarray:
    """``x`` as a flat array of ``dtype``; ValueError unless it holds integers that fit."""
    a = np.asarray(x).reshape(-1)
    if a.size and (a.dtype.kind not in "iu" or a.min() < np.iinfo(dtype).min or a.max() > np.iinfo(dtype).max):
        raise ValueError(f"{name} must be integers of {np.dtype(dtype).name}, got {a.dtype.name}")
    return a.astype(dtype)


def _atomic(path: Path, write) -> None:
    """``write(f)`` into ``path`` through a temporary file, removed again if anything fails."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass  # e.g. the temporary name itself is a directory: nothing of ours to remove
        if isinstance(e, OSError):  # disk full, permissions, a directory in the way: one line
            raise SwarmnavError(f"cannot write {path}: {e.strerror or e}") from None
        raise


def _jsonable(d: dict) -> dict:
    out = {}
    for k, v in d.items():
        v = float(v) if isinstance(v, (np.floating, np.integer, int, float)) and not isinstance(v, bool) else v
        if isinstance(v, float) and not np.isfinite(v):
            v = None if np.isnan(v) else ("inf" if v > 0 else "-inf")
        out[k] = v
    return out
