"""Parameters of the ``sph`` method: Table I of the SPH paper, plus the choices it leaves open."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, ClassVar, Literal

from swarmnav.params import param


#: The paper build's values of the parameters in which it differs from the default build
#: (``swarmnav``); every other preset starts from it.
PAPER: dict[str, Any] = {"plan_v_max": 0.0, "ref_reset": 0.5, "yield_range": 0.0, "goal_reset": 0.0,
                         "band_guard": False, "retime": 0.0, "by_dim": False,
                         "rep_cutoff": 0.0, "crowd_guard": False, "pair_guard": False,
                         "pair_obstacles": False}


@dataclass(frozen=True, slots=True)
class SphParams:
    """SPH swarm navigation (Li et al., RA-L 2025). Table I values unless marked "our choice"."""

    #: Named parameter sets (``--set preset=NAME``). ``swarmnav`` is the default build: our
    #: recommended sets by dimension (``guard`` in 2-D, ``retime`` in 3-D, chosen on training forests
    #: and checked on held-out forests and unseen scenes: docs/methods/sph.md, *Presets*). ``paper``
    #: is Table I and our readings where the paper is silent. ``released`` is the authors' released
    #: code (SmartGroupSystems/SPH-planning, ``water_swarm/launch/sph.launch`` and the C++ it
    #: configures): its controller gains and bounds, its 50 Hz update, its kernel evaluation, its ESDF
    #: force law, its planner limits and its replanning. ``headroom`` is ``paper`` with the tracking
    #: kept below what the swarm forces can hold: the planner plans at 0.8 v_max, so a robot the swarm
    #: held back can catch up, and the position pull is capped at a_max (ref_reset = a_max / k_p).
    #: ``queue`` is ``headroom`` with yielding in narrow places (parts/yielding.py): two robots near an
    #: obstacle pass one after the other. ``guard`` (the 2-D Table II set) is ``queue`` with a
    #: stronger pull on the final approach and no tracking into an obstacle; ``retime`` (the 3-D
    #: Table II set) is ``queue`` with local plans re-timed where the spline cuts its path short.
    #: Every preset but ``swarmnav`` starts from ``paper`` (PAPER below).
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": PAPER,
        "headroom": {**PAPER, "plan_v_max": 0.8, "ref_reset": 0.3},
        "queue": {**PAPER, "plan_v_max": 0.8, "ref_reset": 0.3, "yield_range": 1.2},
        "guard": {**PAPER, "plan_v_max": 0.8, "ref_reset": 0.3, "yield_range": 1.2, "goal_reset": 0.5,
                  "band_guard": True},
        "retime": {**PAPER, "plan_v_max": 0.8, "ref_reset": 0.3, "yield_range": 1.2, "retime": 0.8},
        "released": {
            **PAPER,
            "k_rep": 1.1, "k_vis": 1.8, "k_p": 15.0, "k_v": 6.5, "v_max": 2.5, "a_max": 3.5,
            "plan_v_max": 1.2, "plan_a_max": 1.5, "dt": 0.02, "kernel": "released",
            "env_law": "released", "clip": "axis",
            "ctrl_seed": "released", "ref_reset": 1.0, "ref_clamp": False, "end_state": "rest",
            "swarm_vertical": False,
        },
    }
    #: The preset the defaults are: our recommended sets by dimension (``by_dim``).
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "ours, the default: guard on a 2-D scene, retime on a 3-D scene (by_dim), each chosen on "
                    "training forests and checked on held-out forests and unseen scenes; 2-D swarms of 30 robots or "
                    "more also with the crowd parts (rep_cutoff, crowd_guard, pair_guard)",
        "paper": "Table I and the paper's algorithm, with our readings where it is silent (docs/methods/sph.md): "
                 "the paper rows of docs/reproduction.md (--set preset=paper)",
        "headroom": "ours: paper with the tracking kept below what the swarm forces can hold (plan at 0.8 v_max, "
                    "pull capped at a_max)",
        "queue": "ours: headroom with yielding in narrow places (methods/sph/parts/yielding.py)",
        "guard": "ours, recommended in 2-D (the 2-D Table II set): queue with the final approach's pull and the "
                 "band guard (methods/sph/parts/guard.py)",
        "retime": "ours, recommended in 3-D (the 3-D Table II set): queue with short local plans re-timed",
        "released": "the authors' released code (SmartGroupSystems/SPH-planning): its gains, 50 Hz, kernel, ESDF "
                    "law, planner limits and replanning",
    }

    # --- swarm (Table I) ---
    c: float = param(54.97, "", "(0, inf)", "eq. (4), Table I", "kernel normalisation constant")
    R: float = param(20.0, "m", "(0, inf)", "eq. (1), Table I",
        "connection range; also the perception range (Section IV)")
    h: float = param(10.0, "m", "(0, inf)", "eq. (4), Table I", "kernel radius")
    m: float = param(1.0, "kg", "(0, inf)", "Table I", "particle mass")
    k_den: float = param(1.0, "", "[0, inf)", "Alg. 1 line 8, Table I", "aggregation (density) gain")
    k_rep: float = param(1.0, "m^2/s^2", "[0, inf)", "Alg. 1 line 9, Table I", "dispersion (repulsion) gain")
    k_vis: float = param(1.5, "1/s", "[0, inf)", "Alg. 1 line 10, Table I", "velocity damping")
    k_env: float = param(10.0, "1/s^2", "[0, inf)", "Alg. 1 line 11, Table I", "obstacle gain")
    v_max: float = param(1.0, "m/s", "(0, inf)", "eq. (2), Table I", "speed bound")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "eq. (2), Table I", "acceleration bound")
    rho0: float = param(1e6, "", "(0, inf)", "Alg. 1 line 8, Table I", "reference density")
    gamma: float = param(7.0, "", "(0, inf)", "Section III-A, Table I",
        "density sensitivity (\"gamma = 7\")")
    # --- planning (Table I) ---
    T_p: float = param(0.2, "s", "(0, inf)", "Table I", "replanning interval")
    broadcast_hz: float = param(10.0, "Hz", "[0, 1000]", "Section IV-A",
                                "position broadcast rate (counted in comm_mbps; 64 B messages, planning/messages.py)")
    lambda_s: float = param(5.0, "", "[0, inf)", "eq. (8), Table I", "smoothness weight")
    lambda_c: float = param(1000.0, "", "[0, inf)", "eq. (8), Table I", "collision weight")
    lambda_f: float = param(1.0, "", "[0, inf)", "eq. (8), Table I", "feasibility weight")
    k_p: float = param(5.0, "1/s^2", "[0, inf)", "eq. (13), Table I", "position tracking gain")
    k_v: float = param(3.5, "1/s", "[0, inf)", "eq. (13), Table I", "velocity tracking gain")
    d_thr: float = param(0.5, "m", "(0, inf)", "eqs. (5), (10), Table I", "obstacle safety threshold")
    # --- our choices (the paper does not give them; see docs/methods/sph.md) ---
    dt: float = param(0.01, "s", "[0.0001, 1]", "ours",
        "control step: the text's \">= 100 Hz\" swarm control (Sec. III); released code 0.02")
    kernel: Literal["paper", "released"] = param("paper", "", None, "ours", "eq. (4) as printed, or the released C++")
    env_law: Literal["paper", "released"] = param("paper", "", None, "ours",
        "obstacle force: eqs. (5)-(6), 2 k_env (d_thr - d) along grad d; or the released "
        "calcGradForce, k_force (d - env_safe)^2 along grad d, d measured from obstacles grown by "
        "env_inflation")
    k_force: float = param(1000.0, "1/(m s^2)", "[0, inf)", "released planning/k_force",
        "env_law = released only: gain of the quadratic obstacle force")
    env_safe: float = param(0.4, "m", "[0, inf)", "released planning/safe_distance",
        "env_law = released only: the force acts below this distance")
    env_inflation: float = param(0.1, "m", "[0, inf)", "released sdf_map/obstacles_inflation (0.099)",
        "env_law = released only: the released ESDF is built on obstacles grown by this")
    clip: Literal["norm", "axis"] = param("norm", "", None, "eq. (2)",
        "bound of speed and command: the Euclidean norm (eq. 2), or each axis (the released clamp)")
    swarm_vertical: bool = param(True, "", None, "ours (released: False)",
        "3-D only: Algorithm 1 (density, repulsion, viscosity) acts along every axis (True: the paper "
        "writes it for q in R^3), or in the horizontal plane only, the vertical left to the "
        "tracking law and the obstacle force (False: the released sph_zhang_3d.cpp, whose z command "
        "has no SPH term)")
    r_floor: float = param(0.05, "m", "(0, inf)", "ours", "distance floor in the 1/r repulsion (finite force)")
    rep_cutoff: float = param(3.0, "m", "[0, inf)", "ours",
        "cut-off of the 1/r repulsion (Alg. 1 line 9): only robots closer than this repel, with the "
        "paper's k_rep / r, so a large crowd does not press its edge robots into obstacles "
        "(0 = none, the paper: every visible robot within R)")
    crowd_guard: bool = param(True, "", None, "ours",
        "inside the obstacle band (d < d_thr) the swarm's push (Alg. 1 density and repulsion terms) "
        "loses its component towards the obstacle, as band_guard does for the tracking term: a crowd "
        "may push a robot along an obstacle, never into it")
    pair_guard: bool = param(True, "", None, "ours (Wang, Ames & Egerstedt, T-RO 2017)",
        "each robot's command is changed as little as possible so that no pair of robots closes faster "
        "than both can brake before 2 body radii + pair_margin (safety barrier certificates for double "
        "integrators, each robot half of each pair's constraint): a queue pressed from behind stops "
        "short of contact")
    pair_margin: float = param(0.02, "m", "[0, inf)", "ours",
        "pair_guard: the pair stops this far beyond contact (2 body radii)")
    pair_decel: float = param(0.75, "m/s^2", "(0, inf)", "ours",
        "pair_guard: the braking each robot of a pair is assumed to have (half a_max, the rest left "
        "to the other terms)")
    pair_gamma: float = param(2.0, "1/s", "(0, inf)", "ours (Wang et al.'s class-K function, linear)",
        "pair_guard: how fast a pair may use up its braking margin (dh/dt >= -pair_gamma h)")
    pair_obstacles: bool = param(True, "", None, "ours (Wang, Ames & Egerstedt, T-RO 2017, obstacles as static agents)",
        "pair_guard: each robot's QP also keeps the barrier against every obstacle near it (2-D: one row "
        "per obstacle of the known map; 3-D or sense.map=scans: the nearest, from the robot's field; stop body radius + "
        "pair_margin from its surface, the robot keeping the whole bound), so that the command the guard "
        "moves never drives a robot into a trunk")
    pair_bound: bool = param(False, "", None, "ours",
        "pair_guard: each robot's QP also keeps its command within the dynamics' a_max (the box of "
        "clip=axis exactly, the disc of clip=norm as an inscribed 16-gon, 2 % short of it), so the "
        "dynamics' cut never undoes what the guard asked")
    crowd_size: int = param(30, "", "[1, inf)", "ours",
        "with by_dim (the default build), rep_cutoff, crowd_guard and pair_guard act on 2-D swarms of this many "
        "robots or more; smaller swarms fly the paper's repulsion and no crowd guard (Table II's 15 and "
        "Fig. 3 B's 20 robots were chosen and measured so; 3-D not measured with them yet)")
    esdf_resolution: float = param(0.1, "m", "[0.01, 1]", "ours", "ESDF grid, as the released sdf_map")
    grid_resolution: float = param(0.1, "m", "[0.01, 1]", "ours", "grid-search cell, as the released A*")
    max_map_bytes: int = param(2 * 2**30, "B", "[1, inf)", "ours",
        "largest memory the maps of a run may take (ESDF, the robots' occupancy grids and their searches, "
        "the yield field); a world that needs more at its resolutions is refused before they are allocated "
        "(2 GiB: twice the largest shipped run, sph_cluttered_3d with 30 robots, preset retime and the field "
        "search: 1.05 GiB)")
    inflation: float = param(0.3, "m", "[0, inf)", "ours",
        "grid-search body clearance: body radius 0.2 m + one cell (last tier)")
    plan_clearance: float = param(0.9, "m", "[0, inf)", "ours",
        "first-tier grid-search clearance: d_thr + a body diameter, so a neighbour abreast of "
        "the path at contact distance is still outside the ESDF force band (0 = off)")
    plan_clearance_cost: float = param(2.0, "", "[0, inf)", "ours",
        "extra A* cost per metre inside plan_clearance: detours up to ~2 m per metre of hugging "
        "are preferred (ours)")
    plan_neighbours: float = param(0.0, "m", "[0, inf)", "ours",
        "cells this close to a visible neighbour cost like the wide band in the grid search "
        "(ours; 0 = off, as the paper's planner: on, it made contacts more frequent)")
    plan_neighbours_range: float = param(3.0, "m", "[0, inf)", "ours",
        "only visible neighbours this close enter the search")
    plan_v_max: float = param(0.8, "m/s", "[0, inf)", "ours (released planning/max_vel 1.2)",
        "speed bound of the planner (eq. 11 and the knot span); 0: v_max")
    plan_a_max: float = param(0.0, "m/s^2", "[0, inf)", "ours (released planning/max_acc 1.5)",
        "acceleration bound of the planner (eq. 11); 0: a_max")
    end_state: Literal["moving", "rest"] = param("moving", "", None, "ours",
        "end state of a local plan short of the goal: moving at the planner's speed along the path "
        "(ours), or at rest (released terminal_state)")
    ctrl_spacing: float = param(0.5, "m", "[0.05, 10]", "ours",
        "control-point spacing along the initial path (released dist_p); from 0.05 m (half the "
        "0.1 m map: finer points resolve nothing, and 1e-12 m asked for 1e13 of them)")
    ctrl_seed: Literal["knots", "released"] = param("knots", "", None, "ours",
        "initial interior control points: the path points at the knot times after C_2 (ours, "
        "reference at v_max), or path[1..-2] as the released code (repeats the points C_2 and "
        "C_{K-2} stand for: the reference crawls at ~0.7 v_max)")
    plan_speed: float = param(1.0, "", "(0, 1]", "ours",
        "knot speed of the reference as a fraction of v_max (1: the released beta = v_max / "
        "dist_p)")
    horizon_points: int = param(10, "", "[0, inf)", "ours",
        "path points per local plan (released: first 10); 0 = whole path")
    max_iter: int = param(200, "", "[0, 100000]", "ours", "L-BFGS-B iteration cap (released opt_maxeval)")
    max_expand: int = param(2_000_000, "", "[1, inf)", "ours", "A* expansion cap per search")
    search_3d: Literal["astar", "field"] = param("astar", "", None, "ours",
        "3-D grid search: weighted A* from scratch at every replan (heuristic weight "
        "search_weight_3d), or an optimal path from the map's cost-to-go field (one backward "
        "Dijkstra per map, shared by robots with the same map; a grown map is searched by A* with "
        "an older field as heuristic); the planar search is always A* (weight 1.001)")
    search_weight_3d: float = param(10.0, "", "[1, inf)", "released astar/lambda_heu",
        "search_3d = astar only: heuristic weight of the 3-D A*, the released planner's")
    retime: float = param(0.8, "", "[0, 1]", "ours",
        "a local plan whose spline is shorter than this fraction of the grid path it was seeded "
        "from is optimised again, seeded from its own curve at ctrl_spacing, so that it flies at "
        "the planner's speed (0 = off)")
    replan_from: Literal["state", "reference"] = param("reference", "", None, "ours",
        "start state of a replan (released)")
    ref_reset: float = param(0.3, "m", "[0, inf)", "ours",
        "\"reference\" mode: bound on the reference lag at a replan (ours; released 1.0): k_p "
        "ref_reset = k_rep / (2 body radius) = 2.5 m/s^2, the tracking pull never beats the "
        "contact repulsion")
    goal_reset: float = param(0.5, "m", "[0, inf)", "ours",
        "\"reference\" mode: the lag bound at a replan on the final approach (the robot's last local "
        "plan ended at its goal and it is farther than plan_clearance from every obstacle), where "
        "the only force against the pull is the 1/r push of the robots already gathered at the "
        "goal, which grows with their number (0 = ref_reset everywhere)")
    band_guard: bool = param(True, "", None, "ours",
        "inside the obstacle band (d < d_thr) drop the tracking term's component towards the "
        "obstacle: the reference never presses a robot into an obstacle, the ESDF force and the "
        "swarm alone set how close it comes (False: eq. 13 as printed)")
    by_dim: bool = param(True, "", None, "ours",
        "the recommended set of the scene's dimension and swarm size: on a 2-D scene retime is off "
        "(guard's set), on a 3-D scene goal_reset and band_guard are off (retime's set), rep_cutoff "
        "and crowd_guard act on 2-D scenes of crowd_size robots or more only; False: every value as given")
    start_clearance: float = param(0.0, "m", "[0, inf)", "ours",
        "\"reference\" mode: a replan whose start (the reference state) is closer than this to an "
        "obstacle starts from the robot's measured position and velocity instead, at rest in "
        "acceleration: the reference's velocity there points into the obstacle, and a plan that "
        "starts with it runs on into the obstacle at every replan (0 = off)")
    ref_clamp: bool = param(True, "", None, "ours",
        "beyond ref_reset move the start to ref_reset from the robot (ours; False: onto the "
        "robot, released): the pull stays continuous, no jump of the reference to the robot")
    reset_velocity: bool = param(False, "", None, "ours",
        "on a ref_reset also restart from the measured velocity (ours); the released planner "
        "moves only the start position and keeps the reference's velocity/acceleration")
    ref_hold: float = param(0.0, "m", "[0, inf)", "ours",
        "replanning: a robot's reference clock slows once its lag passes ref_hold / 2 and stops at "
        "ref_hold (v* = phi v, a* = phi^2 a), the position error capped at ref_hold, so the reference "
        "waits for a robot the swarm holds back instead of pulling it on; 0 = off (as once_hold "
        "for plan_once)")
    yield_range: float = param(1.2, "m", "[0, inf)", "ours",
        "yielding in narrow places (methods/sph/parts/yielding.py): of two visible robots closer than "
        "this, one within yield_clearance of an obstacle, the one farther from its goal slows its "
        "reference clock, stopping at yield_range / 2, so they pass one at a time; 0 = off (paper)")
    yield_clearance: float = param(0.7, "m", "[0, inf)", "ours",
        "yield_range > 0 only: a pair yields when one of its robots is this close to an obstacle "
        "(d_thr + a body radius: a robot one body radius off its course enters the obstacle band)")
    yield_resolution: float = param(0.2, "m", "[0.01, 1]", "ours",
        "yield_range > 0 only: grid of the path-length-to-goal field that orders the robots (a "
        "multiple of esdf_resolution; bilinear between nodes)")
    goal_spread: float = param(0.0, "", "[0, inf)", "ours",
        "per-robot goal = goal + goal_spread * (spawn_i - spawn centroid)")
    plan_once: bool = param(False, "", None, "ours", "plan the whole path once at t = 0 (Fig. 3B protocol)")
    once_hold: float = param(0.5, "m", "[0, inf)", "ours",
        "plan_once only: a robot's reference clock slows once its lag passes once_hold / 2 and "
        "stops at once_hold (v* = phi v, a* = phi^2 a), and the position error is capped at "
        "once_hold (ours: k_p once_hold = k_rep / (2 body radius)); 0 = off, the reference runs "
        "on by time alone")
    # --- execution (how a run is computed, not what: left out of run keys) ---
    threads: int = param(1, "", "[1, 64]", "ours",
        "threads that plan robots at a replan (each robot's map update, grid search and spline); "
        "results are identical for any value, so it is not part of a run's key (docs/methods/sph.md, "
        "*Threads*)", results=False)


def for_dim(p: SphParams, dim: int, n: int | None = None) -> SphParams:
    """The parameters a run of ``n`` robots on a ``dim``-D scene flies: ``p`` itself unless
    ``p.by_dim``; with it, the recommended set of that dimension (2-D: ``guard``'s, so ``retime``
    off; 3-D: ``retime``'s, so ``goal_reset`` and ``band_guard`` off) and of that swarm size (the
    crowd parts ``rep_cutoff``, ``crowd_guard`` and ``pair_guard`` on a 2-D scene of ``crowd_size`` robots or
    more only: they were chosen on 2-D forests), the other values as given."""
    if not p.by_dim:
        return p
    if dim != 2 or (n is not None and n < p.crowd_size):  # chosen on 2-D forests; not measured in 3-D yet
        p = replace(p, rep_cutoff=0.0, crowd_guard=False, pair_guard=False)
    if dim == 2:
        return replace(p, retime=0.0)
    return replace(p, goal_reset=0.0, band_guard=False)
