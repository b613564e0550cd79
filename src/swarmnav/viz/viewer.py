"""The replay viewer: one run as one self-contained HTML page (``swarmnav view``).

The page holds the run's data and every script it needs (the viewer's own and three.js r185,
vendored under ``viz/vendor/three``); nothing is fetched when it is opened, so it works
offline from any folder. It shows the run top-down (a 2-D canvas) or in perspective
(three.js with OrbitControls: a 3-D run's obstacles as solids; a planar run at the fixed
altitude of HES Appendix A, Figure A1), with play / pause, speed, a timeline with the
structural events, a strip chart of minimum clearance and sub-swarm count and, when the run
recorded them (``RunResult.plans``), each robot's committed plan ahead of it, and for a quadrotor
run (``RunResult.thrust_axis``) each vehicle's thrust axis, so its tilt shows.

Data are kept small: positions and velocities are quantised to 16 bits per axis against the
run's own box (:func:`quantise`; the largest error is half a step, :func:`quantisation_error`),
delta-coded along time and gzip-compressed before base64; the page inflates them with the
browser's ``DecompressionStream``.
"""

from __future__ import annotations

import base64
import gzip
import html
import json
import math
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from swarmnav.errors import SwarmnavError
from swarmnav.metrics import MetricParams
from swarmnav.viz.draw import label_colors, scenario_of
from swarmnav.viz.draw3d import enclosing
from swarmnav.world.obstacles import Box, Circle, Cylinder, Polygon, Sphere

if TYPE_CHECKING:
    from swarmnav.sim.result import RunResult

#: The vendored three.js release (see viz/vendor/three/README.md).
THREE_VERSION = "0.185.1"
#: Quantisation levels per axis (16 bits).
LEVELS = 65535
#: Fixed flight altitude [m] of a planar run in the perspective view: HES Appendix A, Figure A1.
PLANAR_ALTITUDE = 10.0
#: Height [m] of the slabs a planar run's obstacles become in perspective (our choice: above
#: the 10 m flight plane, so walls read as walls around the arrows).
SLAB_HEIGHT = 12.0
#: Quantisation levels of a quadrotor run's thrust axes per component over [-1, 1] (10 bits: a
#: component is off by at most 1 / 1023, the direction by at most 0.1 deg; 16 bits would double
#: the bytes they add to a page for a precision no drawing shows).
AXIS_LEVELS = 1023
#: Role codes of ``trajectory.npz``'s optional ``roles`` array.
ROLE_NAMES = ("follower", "subleader", "leader")


def quantise(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, levels: int = LEVELS) -> np.ndarray:
    """``x`` (..., d) as uint16 codes: 0 at ``lo``, ``levels`` at ``hi`` per axis (a zero-width
    axis gets a 1 m range). Decoded as ``lo + code * (hi - lo) / levels``."""
    span = np.where(hi > lo, hi - lo, 1.0)
    return np.rint((np.clip(x, lo, hi) - lo) / span * levels).astype(np.uint16)


def axis_error(levels: int = AXIS_LEVELS) -> float:
    """Largest error of a unit vector coded by :func:`quantise` over [-1, 1] per component:
    half a step, 1 / levels, per component, combined over the three (Euclidean)."""
    return math.sqrt(3.0) / levels


def quantisation_error(lo: np.ndarray, hi: np.ndarray) -> float:
    """Largest position error [m] of :func:`quantise` over ``[lo, hi]``: half a step per axis,
    combined over the axes (Euclidean)."""
    span = np.where(hi > lo, hi - lo, 1.0)
    return float(np.sqrt(np.sum((span / LEVELS / 2) ** 2)))


def _blob(a: np.ndarray, delta: bool = False) -> dict[str, Any]:
    """A typed array as ``{dtype, shape, delta, data}``: gzip then base64. ``delta``: uint16
    codes stored as their differences along axis 0 (mod 2^16), which compress far better for
    smooth paths; the page adds them back up."""
    a = np.ascontiguousarray(a)
    if delta:
        d = a.copy()
        d[1:] = a[1:] - a[:-1]  # uint16 arithmetic wraps mod 2^16; the page's cumulative sum wraps back
        a = d
    raw = gzip.compress(a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes(), compresslevel=6, mtime=0)
    return {"dtype": a.dtype.name, "shape": list(a.shape), "delta": delta, "data": base64.b64encode(raw).decode()}


def _obstacles(scn) -> list[dict[str, Any]]:
    """The scene's obstacles in the page's compact form."""
    out = []
    lo, hi = scn.lower, scn.upper
    for o in scn.obstacles:
        if isinstance(o, Circle):
            out.append({"t": "circle", "c": list(o.center), "r": o.radius})
        elif isinstance(o, Sphere):
            out.append({"t": "sphere", "c": list(o.center), "r": o.radius})
        elif isinstance(o, Cylinder):
            out.append({"t": "cylinder", "c": list(o.center), "r": o.radius, "z": list(o.z)})
        elif isinstance(o, (Box, Polygon)):
            item = {"t": "prism" if o.z is not None else "polygon", "v": o.vertices().round(6).tolist()}
            if o.z is not None:
                item["z"] = list(o.z)
                item["shell"] = bool(scn.dim == 3 and enclosing(o, lo, hi))  # a wall of the world box
            out.append(item)
        else:  # a new obstacle type must be taught to the viewer, not silently dropped
            raise SwarmnavError(f"the viewer cannot draw obstacle {o!r}")
    return out


def viewer_data(result: RunResult) -> dict[str, Any]:
    """The page's data: run description, scene, events and the quantised arrays."""
    scn = scenario_of(result)
    P = np.asarray(result.positions, dtype=float)
    if P.ndim != 3 or P.shape[0] < 1 or P.shape[2] not in (2, 3):
        raise SwarmnavError(f"positions must be (K + 1, N, 2 or 3), got {P.shape}")
    K, N, d = P.shape[0] - 1, P.shape[1], P.shape[2]
    if not np.isfinite(P).all():
        raise SwarmnavError("positions are not all finite; nothing to replay")
    plans = getattr(result, "plans", None)
    plans = plans if plans is not None and len(plans) else None
    lo = np.minimum(scn.lower[:d], P.reshape(-1, d).min(axis=0))
    hi = np.maximum(scn.upper[:d], P.reshape(-1, d).max(axis=0))
    if plans is not None and len(plans.points):  # a plan may leave the world: the box holds it too
        lo = np.minimum(lo, plans.points.min(axis=0))
        hi = np.maximum(hi, plans.points.max(axis=0))
    V = np.asarray(result.velocities, dtype=float)
    vmax = float(np.max(np.abs(V))) if V.size and np.isfinite(V).all() else 0.0
    vmax = vmax if vmax > 0 else 1.0
    C = np.asarray(result.clearance, dtype=float)
    finite = C[np.isfinite(C)]
    c_lo, c_hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    c_hi = c_hi if c_hi > c_lo else c_lo + 1.0
    c_code = np.where(np.isfinite(C), np.rint((np.clip(C, c_lo, c_hi) - c_lo) / (c_hi - c_lo) * (LEVELS - 1)),
                      LEVELS).astype(np.uint16)  # LEVELS: no obstacle (+inf)
    idx, palette = label_colors(result.labels)
    ids = np.unique(result.labels)
    idx = idx.astype(np.uint8 if len(ids) <= 256 else np.uint16)
    dt = float(result.config.get("dt", 1.0))
    m = result.metrics
    arrays = {
        "positions": _blob(quantise(P, lo, hi), delta=True),
        "velocities": _blob(quantise(V, np.full(d, -vmax), np.full(d, vmax)), delta=True),
        "clearance": _blob(c_code),
        "labels": _blob(idx),
        "min_clearance": _blob(np.where(np.isfinite(result.min_clearance), result.min_clearance, np.nan)
                               .astype("<f4")),
        "n_subswarms": _blob(result.n_subswarms.astype("<u2")),
    }
    roles = getattr(result, "roles", None)
    if roles is not None:
        arrays["roles"] = _blob(np.asarray(roles, dtype=np.uint8))
    if plans is not None:  # committed trajectories: points coded as the positions; times [s] as
        # float32 from each plan's commit, to 1 ms (the same few values in every plan: they compress)
        since = plans.times - np.repeat(plans.step * dt, np.diff(plans.offsets))
        arrays |= {"plan_step": _blob(plans.step.astype("<u4")), "plan_robot": _blob(plans.robot.astype("<u4")),
                   "plan_offsets": _blob(plans.offsets.astype("<u4")),
                   "plan_points": _blob(quantise(plans.points.astype(float), lo, hi), delta=True),
                   "plan_tau": _blob(np.round(since, 3).astype("<f4"))}
    thrust = None
    axis = getattr(result, "thrust_axis", None)
    if axis is not None:  # a quadrotor run: each agent's body z axis, 10-bit codes per component
        A = np.asarray(axis, dtype=float)
        if A.shape != (K + 1, N, 3) or not np.isfinite(A).all():
            raise SwarmnavError(f"thrust_axis must be finite, (K + 1, N, 3) = {(K + 1, N, 3)}, got {A.shape}")
        arrays["thrust_axis"] = _blob(quantise(A, -np.ones(3), np.ones(3), AXIS_LEVELS), delta=True)
        tilt = np.degrees(np.arccos(np.clip(A[..., 2], -1.0, 1.0)))  # [deg] from the vertical
        ks, i = np.unravel_index(int(np.argmax(tilt)), tilt.shape)
        thrust = {"levels": AXIS_LEVELS, "error": axis_error(), "tilt_max": float(tilt[ks, i]), "step": int(ks),
                  "agent": int(i)}
    plane = result.config.get("plane")
    return {
        "format": 1,
        "title": f"{result.config.get('method', '?')} on {scn.name}, seed {result.config.get('seed', '?')}",
        "method": result.config.get("method"), "scene": scn.name, "seed": result.config.get("seed"),
        "K": K, "N": N, "dim": d, "dt": dt, "periodic": bool(scn.periodic),
        "world": {"lo": scn.lower.tolist(), "hi": scn.upper.tolist()},
        "quant": {"lo": lo.tolist(), "hi": hi.tolist(), "levels": LEVELS, "error": quantisation_error(lo, hi),
                  "vmax": vmax, "clearance": [c_lo, c_hi]},
        "goal": list(np.asarray(scn.goal, dtype=float)),
        "path": np.asarray(scn.path, dtype=float).tolist() if scn.path else [],  # waypoints a method follows
        "obstacles": _obstacles(scn),
        "palette": [f"#{int(r * 255):02x}{int(g * 255):02x}{int(b * 255):02x}" for r, g, b, _ in palette],
        "label_ids": ids.tolist(),
        "roles": list(ROLE_NAMES) if roles is not None else None,
        "plans": None if plans is None else {"count": len(plans), "points": int(len(plans.points))},
        "d_safe": MetricParams().d_safe,
        "altitude": PLANAR_ALTITUDE if d == 2 else (plane or {}).get("z_fly"),
        "slab_height": SLAB_HEIGHT,
        "plane": plane,
        "events": [{"step": int(e.get("step", 0)), "action": str(e.get("action", "event")),
                    "source": str(e.get("source", "")), "reason": str(e.get("reason", ""))[:200]}
                   for e in result.events],
        **({"thrust": thrust} if thrust is not None else {}),  # a point-mass run's data as before
        "metrics": {k: (float(m[k]) if isinstance(m.get(k), (int, float)) and math.isfinite(m[k]) else None)
                    for k in ("Y", "R_goal", "E_mean", "R_unsafe", "d_clr_min") if k in m},
        "arrays": arrays,
    }


def llm_marks(run_dir: str | Path) -> list[dict[str, Any]]:
    """Timeline marks of the LLM calls in a run directory's ``llm_transcript.jsonl`` (none
    without one; docs/llm.md gives its fields): action ``llm`` for a call the model answered,
    ``llm fallback`` for one answered by the rule after a failure."""
    path = Path(run_dir) / "llm_transcript.jsonl"
    if not path.exists():
        return []
    marks = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
            step = int(r["step"])
        except (json.JSONDecodeError, KeyError, TypeError, ValueError):
            raise SwarmnavError(f"{path}: line {n} is not a transcript record with a step") from None
        fallback = r.get("fallback")
        reason = (f"failed ({fallback}); the rule answered {r.get('rule_action')}" if fallback else
                  f"proposed {r.get('parsed')}, executed {r.get('executed')}")
        marks.append({"step": step, "action": "llm fallback" if fallback else "llm",
                      "source": str(r.get("model") or r.get("backend") or "llm"), "reason": reason})
    return marks


def _asset(*parts: str) -> str:
    return resources.files("swarmnav.viz").joinpath(*parts).read_text("utf-8")


def _libraries() -> dict[str, str]:
    """Sources of three.js (core and module build) and OrbitControls, as vendored."""
    return {"core": _asset("vendor", "three", "three.core.min.js"),
            "three": _asset("vendor", "three", "three.module.min.js"),
            "orbit": _asset("vendor", "three", "OrbitControls.js")}


def _script_text(s: str) -> str:
    """``s`` safe inside a <script> element (no ``</script`` can end it early)."""
    return s.replace("</", "<\\/")


def page(data: dict[str, Any], *, shared: str | None = None) -> str:
    """The viewer page for ``data`` (from :func:`viewer_data`).

    Args:
        shared: None for a self-contained page (libraries and script inline); else the
            relative URL of a folder holding ``viewer-lib.js`` (see :func:`write_shared`),
            loaded with a classic <script src>, so many pages share one copy.
    """
    if shared is None:
        sources = _libraries()
        if any("</script" in v.lower() for v in sources.values()):  # verbatim text: it must not end the element
            raise SwarmnavError("a vendored library contains '</script'; it cannot be inlined as text")
        libs = "\n".join(f'<script type="text/plain" id="lib-{k}">{v}</script>' for k, v in sources.items())
        app = f"<script>\n{_script_text(_asset('viewer', 'viewer.js'))}\n</script>"
    else:
        base = html.escape(shared.rstrip("/"), quote=True)
        libs = f'<script src="{base}/viewer-lib.js"></script>'
        app = f'<script src="{base}/viewer.js"></script>'
    template = _asset("viewer", "viewer.html")
    return (template.replace("{{TITLE}}", html.escape(data["title"]))
            .replace("{{STYLE}}", _asset("viewer", "viewer.css"))
            .replace("{{DATA}}", _script_text(json.dumps(data, separators=(",", ":"), allow_nan=False)))
            .replace("{{LIBS}}", libs)
            .replace("{{APP}}", app))


def write_shared(folder: str | Path) -> Path:
    """Write ``viewer-lib.js`` (the vendored libraries as strings) and ``viewer.js`` into
    ``folder``, for pages made with ``page(..., shared=...)``."""
    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    lib = "window.SWARMNAV_LIBS = " + json.dumps(_libraries()) + ";\n"
    (d / "viewer-lib.js").write_text(lib, encoding="utf-8")
    (d / "viewer.js").write_text(_asset("viewer", "viewer.js"), encoding="utf-8")
    return d


def write_viewer(result: RunResult, out_html: str | Path, *, shared: str | None = None,
                 marks: list[dict[str, Any]] = ()) -> Path:
    """Write the viewer page of ``result`` to ``out_html`` (self-contained unless ``shared``);
    ``marks`` are more timeline marks (e.g. :func:`llm_marks`), in the events' form."""
    out = Path(out_html)
    out.parent.mkdir(parents=True, exist_ok=True)
    data = viewer_data(result)
    data["events"] = sorted(data["events"] + list(marks), key=lambda e: e["step"])
    text = page(data, shared=shared)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(out)
    return out
