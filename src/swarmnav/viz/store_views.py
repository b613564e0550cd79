"""Replay viewers of the runs of a results store, linked from ``swarmnav report``.

A store keeps, per finished run, ``trajectories/kk/KEY.npz`` with positions (float32),
sub-swarm labels and the minimum clearance per step, and for a quadrotor run each vehicle's
thrust axis (float32, drawn as the run's own viewer draws it; docs/experiments.md), not the
whole run directory. A store written before the thrust axes were kept opens as before, its
quadrotor runs' viewers without attitude. The viewer of such a run rebuilds the rest from what is stored, and says so on the
page: velocities are central differences of the positions over the method's dt; each agent's
clearance is the signed distance of its stored position to the scene (the simulator's own
function); split and merge marks are the steps where the sub-swarm count rises or falls; an
LLM run's transcript, kept beside its trajectory, gives a mark per call.

Pages go to ``DIR/report_files/viewers/KEY.html`` and share one copy of the scripts
(``viewer-lib.js``, ``viewer.js``) in that folder; a page whose file exists is kept (a key names
one configuration, so its run never changes), so a report after a resumed sweep only writes
the new ones.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from swarmnav.errors import SwarmnavError
from swarmnav.viz.viewer import llm_marks, page, viewer_data, write_shared

#: Folder of the viewers, relative to the results directory.
FOLDER = Path("report_files") / "viewers"


def derived_events(labels: np.ndarray) -> list[dict]:
    """Split / merge events from (K + 1, N) sub-swarm labels: a step ``k`` where the count of
    sub-swarms rises from ``k`` to ``k + 1`` is a split, where it falls a merge (the step
    convention of the simulator's event log)."""
    lab = np.sort(np.asarray(labels), axis=1)
    count = 1 + np.count_nonzero(np.diff(lab, axis=1), axis=1)
    out = []
    for k in np.flatnonzero(np.diff(count)):
        out.append({"step": int(k), "action": "split" if count[k + 1] > count[k] else "merge",
                    "source": "derived", "reason": f"sub-swarms {count[k]} -> {count[k + 1]} (from the stored labels)"})
    return out


def _run_of(root: Path, row: dict, dt_of, scene_of) -> object:
    """A RunResult rebuilt from one store row and its trajectory file."""
    from swarmnav.sensing import signed_distance
    from swarmnav.sim import RunResult

    with np.load(root / row["trajectory"]) as z:
        P = z["positions"].astype(float)
        labels = z["labels"]
        axis = z["thrust_axis"] if "thrust_axis" in z.files else None  # a quadrotor run stored since they are kept
    scn = scene_of(row)
    dt = dt_of(row)
    V = np.gradient(P, dt, axis=0) if len(P) > 1 else np.zeros_like(P)
    geom = scn.geometry
    C = np.full(P.shape[:2], np.inf) if geom.is_empty else \
        signed_distance(geom, P.reshape(-1, P.shape[2])).reshape(P.shape[:2])
    config = {"method": row["method"], "seed": row["seed"], "steps": len(P) - 1, "dt": dt,
              "scenario": scn.to_dict(), "params": row["params"]}
    return RunResult(config=config, positions=P, velocities=V, clearance=C, labels=labels, thrust_axis=axis,
                     events=derived_events(labels), metrics=row["metrics"])


def write_store_viewers(directory: str | Path, experiment: str | None = None,
                        progress: bool = False) -> tuple[dict[str, str], list[str]]:
    """Write a viewer for each finished run of ``experiment`` (default: the last one run) that
    has a trajectory file and no viewer yet.

    Returns:
        ``(links, problems)``: run key -> the viewer's path relative to ``directory``, and one
        line per run whose viewer could not be made (its scene file moved, ...).
    """
    from swarmnav.experiments.runner import job_rows
    from swarmnav.experiments.store import DB_NAME, Store

    root = Path(directory)
    if not (root / DB_NAME).exists():
        raise SwarmnavError(f"{root}: no results store ({DB_NAME})")
    store = Store(root)
    experiment = experiment or store.meta("last_experiment")
    meta = store.meta(f"experiment:{experiment}")
    if meta is None:
        raise SwarmnavError(f"{root}: no experiment '{experiment}' in the store")
    rows = [r for r in job_rows(store, meta) if r["status"] == "done" and r["trajectory"]]
    links: dict[str, str] = {}
    problems: list[str] = []
    if not rows:
        return links, problems
    folder = root / FOLDER
    write_shared(folder)
    dts: dict[str, float] = {}

    def dt_of(row: dict) -> float:
        """The run's step [s]: its resolved parameters name it (every registered method has a
        ``dt``); else the method made from the variant's declared parameters says it (the
        resolved set of an older version may name parameters that no longer exist)."""
        from swarmnav.methods import registry
        from swarmnav.sim.rollout import is_run_option

        resolved = (row.get("config") or {}).get("params") or {}
        if isinstance(resolved.get("dt"), (int, float)):
            return float(resolved["dt"])
        params = {k: v for k, v in row["params"].items() if not is_run_option(k)}
        key = row["method"] + json.dumps(params, sort_keys=True, default=str)
        if key not in dts:
            dts[key] = float(registry.make(row["method"], **params).dt)
        return dts[key]

    scenes: dict[tuple, object] = {}

    def scene_of(row: dict):  # seeds of one variant share their scene (unless it names {seed})
        from swarmnav.world.catalog import load_scenario

        key = (row["scenario"], row["n"])
        if key not in scenes:
            scenes[key] = load_scenario(row["scenario"], n=row["n"])
        return scenes[key]

    todo = [r for r in rows if not (folder / f"{r['key']}.html").exists()]
    for j, row in enumerate(rows):
        out = folder / f"{row['key']}.html"
        if not out.exists():
            try:
                data = viewer_data(_run_of(root, row, dt_of, scene_of))
            except (SwarmnavError, OSError, ValueError, KeyError) as e:
                why = str(e).split(";")[0][:160]  # the first clause: a parameter list can run for lines
                problems.append(f"{row['variant']} seed {row['seed']}: no viewer ({why})")
                continue
            transcript = [a for a in row.get("artifacts") or [] if Path(a).name == "llm_transcript.jsonl"]
            if transcript:  # an LLM run keeps its transcript beside the trajectory: one mark per call
                try:
                    data["events"] = sorted(data["events"] + llm_marks((root / transcript[0]).parent),
                                            key=lambda e: e["step"])
                except SwarmnavError as e:
                    problems.append(f"{row['variant']} seed {row['seed']}: no LLM marks ({e})")
            data["title"] += f" ({row['variant']})"
            data["note"] = ("from the results store: speeds are differences of stored positions, split / merge "
                            "marks come from the sub-swarm labels"
                            + ("; thrust axes as flown" if "thrust" in data else ""))
            tmp = out.with_name(out.name + ".tmp")
            tmp.write_text(page(data, shared="."), encoding="utf-8")
            tmp.replace(out)
            if progress and (j % 20 == 19 or j == len(rows) - 1):
                print(f"  viewers: {j + 1}/{len(rows)} ({len(todo)} new)", file=sys.stderr)
        links[row["key"]] = (FOLDER / out.name).as_posix()
    return links, problems
