"""The Vicsek family of HWVEM (Aerospace 2021): VEM, VEM-A, IVEM, IVEM-A, WVEM and HWVEM.

One class runs all six models; they differ only in the heading rule (``kernels.genuine_heading``).
Every step of :meth:`VicsekFamily.act` follows Algorithm 1 of the paper:

1. neighbour list of the current positions (cell list, sparse CSR);
2. reference heading theta_d of the information UAV (fixed, or from its path);
3. genuine desired heading theta^g (eq. 18 = eq. 9 without the avoiding neighbours) plus noise;
4. obstacle avoidance: the agents meeting eq. (20)-(21) take the tangent heading (eq. 22);
5. velocity: alignment v0 (cos theta, sin theta) (eq. 7) plus repulsion and attraction
   (eq. 23-25), capped at v_max (eq. 26);
6. layers for the next step from the current neighbours and layers (eq. 5).

The kinematics x(k+1) = x(k) + v(k+1) (eq. 8) are ``swarmnav.dynamics.Kinematic`` with dt = 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from swarmnav.dynamics import Kinematic
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.methods.vicsek import kernels as K
from swarmnav.methods.vicsek.geometry import Polyline, avoidance, pursue, wrap
from swarmnav.methods.vicsek.measures import deg_con
from swarmnav.methods.vicsek.networked import AVOIDING, LAYER, NUMBER, THETA, pictures
from swarmnav.params import build, param
from swarmnav.sensing import signed_distance
from swarmnav.world.scenario import Scenario

#: Registered names and their heading rules.
MODELS = {"vem": K.VEM, "vem-a": K.VEM_A, "ivem": K.IVEM, "ivem-a": K.IVEM_A, "wvem": K.WVEM, "hwvem": K.HWVEM}
#: Models with an information UAV.
WITH_INFO_UAV = ("vem-a", "ivem-a", "wvem", "hwvem")
_IVEM_RULES = {"printed": K.IVEM_PRINTED, "middle": K.IVEM_MIDDLE, "printed-circular": K.IVEM_PRINTED_CIRCULAR,
               "middle-circular": K.IVEM_MIDDLE_CIRCULAR}
_NORMS = {"l1": K.NORM_L1, "l2": K.NORM_L2, "linf": K.NORM_LINF}
_NO_NOISE = np.zeros(0)
_NO_FORCE = np.zeros((0, 2))


@dataclass(frozen=True, slots=True)
class VicsekParams:
    """Parameters of the Vicsek family. Defaults are the mission settings of HWVEM Section 3.2;
    the alignment study of Section 3.1 sets v0 = 0.03, eta = 0, c_rep = c_att = 0."""

    #: Named parameter sets (``--set preset=NAME``) of the paper's Sections 3.1-3.2. ``mission`` is the
    #: default build; ``paper`` differs from it only in the seam of a periodic box (``wrap_neighbours``),
    #: the reading Table 1 needs; ``alignment`` is Section 3.1's study in that reading.
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "mission": {},  # Sec. 3.2, the defaults (HWVEM-I weights)
        "paper": {"wrap_neighbours": False},  # Sec. 3.2, no interaction across a periodic box's seam
        "hwvem-i": {"p1": 0.1, "p2": 5.0},  # Sec. 3.2
        "hwvem-ii": {"p1": 0.0, "p2": 100.0},  # Sec. 3.2
        # Sec. 3.1 (Table 1, Figs. 5-6): no attraction / repulsion, no interaction across the seam
        "alignment": {"v0": 0.03, "eta": 0.0, "c_rep": 0.0, "c_att": 0.0, "wrap_neighbours": False},
    }
    DEFAULT_BUILD: ClassVar[str] = "mission"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "mission": "Section 3.2's mission settings (HWVEM-I weights) and our readings; in a periodic box "
                   "neighbours interact across the seam (minimum image, ours)",
        "paper": "Section 3.2's settings in the paper's reading of the periodic box: agents wrap but do not "
                 "interact across its seam, so the information UAV's lower-left corner is a real place (the "
                 "reading that reproduces Table 1, docs/methods/vicsek.md); no effect without a periodic box",
        "hwvem-i": "Section 3.2's HWVEM-I layer weights (p1 = 0.1, p2 = 5)",
        "hwvem-ii": "Section 3.2's HWVEM-II layer weights (p1 = 0, p2 = 100)",
        "alignment": "Section 3.1's alignment study (Table 1, Figs. 5-6) in the paper's reading of the seam",
    }

    dt: float = param(1.0, "step", "[0.001, 1000]", "eq. (8)",
        "time step: eq. (8) advances one step with x(k+1) = x(k) + v(k+1)")
    v0: float = param(0.1, "m/step", "[0, inf)", "eq. (7), Sec. 3.2, Sec. 3.1",
        "constant speed; Sec. 3.2 (Sec. 3.1: 0.03)")
    r: float = param(1.0, "m", "(0, inf)", "Sec. 3.1-3.2", "interaction radius r (= r_align)")
    eta: float = param(0.1, "rad", "[0, 2pi]", "eq. (6), Sec. 3.2, Sec. 3.1",
        "noise intensity, d_theta ~ U[-eta/2, eta/2]; Sec. 3.2 (Sec. 3.1: 0)")
    c_align: float = param(1.0, "", "[0, inf)", "eq. (25), Sec. 3.2", "alignment coefficient")
    c_rep: float = param(0.1, "", "[0, inf)", "eq. (25), Sec. 3.2, Sec. 3.1",
        "repulsion coefficient, Sec. 3.2 (Sec. 3.1 ignores the term: 0)")
    r_rep: float = param(0.7, "m", "(0, inf)", "eq. (24), Sec. 3.2", "repulsion range")
    c_att: float = param(0.003, "", "[0, inf)", "eq. (25), Sec. 3.2, Sec. 3.1",
        "attraction coefficient, Sec. 3.2 (Sec. 3.1: 0)")
    r_att: float = param(1.0, "m", "(0, inf)", "eq. (23), Sec. 3.2", "attraction range")
    v_max: float = param(0.1, "m/step", "(0, inf)", "eq. (26)", "speed cap")
    reference: float = param(math.pi / 4, "rad", "[-inf, inf]", "Sec. 3.1",
        "theta_d of the information UAV in a periodic world")
    # HWVEM, eq. (14)-(17). HWVEM-I: p1 = 0.1, p2 = 5; HWVEM-II: p1 = 0, p2 = 100 (Sec. 3.2).
    p1: float = param(0.1, "", "[0, inf)", "eq. (14)", "absolute layer weight offset")
    p2: float = param(5.0, "", "[1, inf)", "eq. (15)", "relative layer weight base")
    nei_weight: bool = param(True, "", None, "eq. (17), Fig. 6",
        "neighbourhood-layer-status weight eq. (17) on (False: ablation)")
    # WVEM weights of the information UAV, its direct neighbours and the rest (Sec. 3.1.2).
    k_alpha: float = param(30.0, "", "(0, inf)", "Sec. 3.1.2", "WVEM weight of the information UAV")
    k_beta: float = param(18.0, "", "(0, inf)", "Sec. 3.1.2", "WVEM weight of its direct neighbours")
    k_gamma: float = param(1.0, "", "(0, inf)", "Sec. 3.1.2", "WVEM weight of the rest")
    info_weight: float = param(100.0, "", "(0, inf)", "Sec. 3.1.2", "IVEM-A weight of the information UAV")
    # Layers before the first step (our choice, see docs/methods/vicsek.md): "bfs" = the
    # hierarchy of the initial neighbour graph exists at k = 0; "unknown" = only the
    # information UAV has a layer and eq. (5) spreads the others one hop per step.
    initial_layers: Literal["bfs", "unknown"] = param("bfs", "", None, "ours", "layers before the first step")
    # Periodic worlds: neighbours across the seam of the box (minimum image). False: agents
    # interact only by the plain distance of their wrapped positions (our choice to expose,
    # see docs/methods/vicsek.md).
    wrap_neighbours: bool = param(True, "", None, "ours", "periodic worlds: neighbours across the seam (minimum image)")
    avoidance: bool = param(True, "", None, "Section 2.3", "obstacle-avoidance mechanism")
    # How an avoiding agent "moves along the tangent direction" (our choice, see
    # docs/methods/vicsek.md): "tangent" = its velocity points along theta_obs with the speed of
    # eq. (26); "heading" = theta_obs only replaces the heading in the alignment term of eq. (25).
    avoid_velocity: Literal["tangent", "heading"] = param("tangent", "", None, "ours",
        "how an avoiding agent moves along the tangent: its velocity, or its heading only")
    r_avoid: float = param(0.5, "m", "[0, inf)", "eq. (20), Sec. 2.3", "trigger distance")
    theta_obstruct: float = param(11 * math.pi / 20, "rad", "[0, pi]", "eq. (21), Sec. 2.3",
        "trigger half-angle")
    # Which genuine direction the trigger of eq. (21) tests (our choice, see docs/methods/vicsek.md):
    # "new" = theta^g(k+1) just computed (with its noise), the direction the agent is about to
    # fly; "previous" = theta^g(k), the index eq. (21) is printed with.
    trigger_heading: Literal["new", "previous"] = param("new", "", None, "ours",
        "which genuine heading the trigger of eq. (21) tests")
    lookahead: float = param(1.0, "m", "(0, inf)", "ours",
        "carrot distance of the information UAV's path following (= r)")
    deg_con_d: float = param(0.9984, "", "[0, 1]", "Sec. 3.1", "desired consistency degree")
    # The norm of eq. (28), which the paper does not name (audit: docs/methods/vicsek.md). L2
    # reproduces Table 1's baselines (100 runs per cell, with ivem_range = raw: 17 of 18 cells
    # within 30 % of the paper; L1, our default before issue 21, made VEM, VEM-A and WVEM
    # 1.5-2.2x and IVEM up to 34x slower than published); HWVEM, limited by how fast its layers
    # spread, moves by 2-6 steps.
    deg_con_norm: Literal["l1", "l2", "linf"] = param("l2", "", None, "eq. (28), Table 1 (our reading)",
        "norm of eq. (28): ||theta - theta_d|| / N with the L2 (Euclidean), L1 or L-infinity norm")
    # IVEM, eq. (30)-(31) (audit: docs/methods/vicsek.md): "printed" = theta_i + lambda (max - min)/2,
    # an agent between its neighbours' extremes keeps its heading; "middle" = (max + min)/2, the
    # text's "moving toward the middle of two neighbours' motion directions with the maximum
    # deviation"; "-circular": max and min of the neighbours' headings relative to the agent's own.
    ivem_rule: Literal["printed", "middle", "printed-circular", "middle-circular"] = param(
        "printed", "", None, "eq. (30)-(31), Sec. 3.1.2 (our reading)",
        "IVEM update: the printed eq. (30)-(31), or the middle of the extreme neighbours' headings")
    # Which numbers eq. (30)-(31) compare (audit: docs/methods/vicsek.md): "signed" = headings in
    # [-pi, pi); "unsigned" = in [0, 2 pi), the range Sec. 2.2 draws the initial headings from;
    # "raw" = as the equations leave them, never wrapped: drawn in [0, 2 pi), eq. (30)'s sums
    # as they come, the arc tangent of eq. (6)/(9) in [-pi, pi] for the weighted rows (IVEM-A next
    # to the information UAV), theta_d for the information UAV. The circular readings ignore it.
    ivem_range: Literal["signed", "unsigned", "raw"] = param("raw", "", None,
        "eq. (30)-(31), Sec. 2.2 (our reading)",
        "IVEM compares headings as numbers in [-pi, pi) (signed), [0, 2 pi) (unsigned) or unwrapped (raw)")
    ivem_self: bool = param(False, "", None, "eq. (30)-(31), Sec. 2.2 (our reading)",
        "IVEM: the agent's own heading counts among its neighbours' min and max")
    # Layers during the run (audit: docs/methods/vicsek.md): "eq5" = l_i(k) = 1 + min l_j(k-1)
    # over the previous neighbours (Sec. 2.1, one hop per step); "eq4" = the shortest neighbour
    # sequence of the current graph every step (Algorithm 1, line 13: "update ... with (4)").
    layer_update: Literal["eq5", "eq4"] = param("eq5", "", None, "eq. (4)-(5), Algorithm 1 (our reading)",
        "how the layers follow the graph: eq. (5) with its one-step delay, or eq. (4) afresh")
    stop_at_convergence: bool = param(False, "", None, "ours",
        "end the run once Deg_con >= deg_con_d held converge_hold steps")
    converge_hold: int = param(20, "step", "[1, inf)", "ours",
        "how long Deg_con must hold before stopping")
    # Mission success, eq. (32) (our choice of test, see docs/methods/vicsek.md): an agent
    # succeeds if it is with the information UAV at the first and the last step and never
    # apart from it for more than follow_gap consecutive steps. "component": in the
    # information UAV's connected component of the interaction graph (radius r);
    # "distance": within follow_radius of it.
    follow_test: Literal["component", "distance"] = param("component", "", None, "ours",
        "mission success test of eq. (32): same graph component, or within follow_radius")
    follow_radius: float = param(3.0, "m", "(0, inf)", "ours", "for follow_test = \"distance\"")
    follow_gap: int = param(10, "step", "[0, inf)", "ours",
        "longest time apart from the information UAV (r / v0 = 10 steps: one interaction radius)")
    # D_ind and D_obs of Table 2 ("the minimum distance between individuals ... and the minimum
    # distance from the individual to the obstacle during the entire process"; audit:
    # docs/methods/vicsek.md): over which agents, and from which step on (0 = the initial
    # placement counts, 1 = only the flight).
    safety_agents: Literal["all", "successful"] = param("all", "", None, "Sec. 3.2 (our reading)",
        "agents D_ind and D_obs are taken over: all, or those that pass the success test of eq. (32)")
    safety_from: int = param(0, "step", "[0, inf)", "Sec. 3.2 (our reading)",
        "first step counted in D_ind and D_obs (0: the initial placement counts)")


class VicsekFamily:
    """One of the six models, chosen by ``model`` (a key of :data:`MODELS`)."""

    dims = (2,)  # headings are planar angles: a 3-D scene is flown in its horizontal slice at z_fly
    networked = True  # neighbours' positions, headings and layers only through the network (networked.py)

    def __init__(self, model: str, **overrides: Any):
        if model not in MODELS:
            raise ConfigError(f"unknown Vicsek model {model!r} (known: {', '.join(MODELS)})")
        self.name = model
        self.code = MODELS[model]
        self.params = p = build(VicsekParams, overrides, context=model)
        if not p.r_att >= p.r_rep:  # eq. (23)-(24): attraction acts beyond the repulsion range
            raise ConfigError(f"{model}: need r_att >= r_rep, got r_att={p.r_att}, r_rep={p.r_rep}")
        self.dt = p.dt
        self.dynamics = Kinematic(v_max=p.v_max)
        self.has_info = model in WITH_INFO_UAV

    # ------------------------------------------------------------------ reset

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        x = np.asarray(positions, dtype=np.float64)
        n = len(x)
        self.n = n
        self.box = float(scenario.bounds[2] - scenario.bounds[0]) if scenario.periodic else 0.0
        self.dynamics = Kinematic(v_max=p.v_max, box=self.box if scenario.periodic else None)
        self.obstacles = None if scenario.geometry.is_empty else scenario.geometry
        self.geom = self.obstacles if p.avoidance else None  # geometry the avoidance rule sees
        # Neighbour radius: the largest of the alignment, repulsion and attraction ranges in use.
        self.radius = max(p.r, p.r_rep if p.c_rep else 0.0, p.r_att if p.c_att else 0.0)
        self._idx = np.empty(max(64, 32 * n), dtype=np.int64)
        self._d2 = np.empty(max(64, 32 * n), dtype=np.float64)

        self.iu = info_uav_index(scenario, x) if self.has_info else -1
        self.path = None
        if self.has_info and not scenario.periodic:
            pts = scenario.path if scenario.path else (tuple(x[self.iu]), scenario.goal)
            self.path = Polyline.of(pts)
        self.s_path = 0.0
        drawn = rng.uniform(0.0, 2 * np.pi, n)  # Sec. 2.2: uniform on [0, 2 pi)
        self.theta = wrap(drawn)
        if self.has_info:
            self.theta[self.iu] = self._theta_d(x)
        # ivem_range = raw: the numbers eq. (30)-(31) compare, never wrapped (None otherwise)
        self.theta_num = None
        if self.code in (K.IVEM, K.IVEM_A) and p.ivem_range == "raw":
            self.theta_num = drawn.copy()
            if self.has_info:
                self.theta_num[self.iu] = self.theta[self.iu]
        self.theta_g = self.theta.copy()
        self.avoiding = np.zeros(n, dtype=np.bool_)

        nb = self._neighbours(x)
        self.layers = np.full(n, K.NO_LAYER, dtype=np.int64)
        if self.has_info:
            if p.initial_layers == "bfs":
                K.bfs_layers(*nb, p.r * p.r, self.iu, self.layers)
            else:
                self.layers[self.iu] = 1

        # run bookkeeping
        self.deg_series: list[float] = [self._deg_con()]
        self._streak = 1 if self.deg_series[-1] >= p.deg_con_d else 0
        self.mission = self.has_info and not scenario.periodic
        self._apart = np.zeros(n, dtype=np.int64)  # current run of steps away from the IU
        self._failed = np.zeros(n, dtype=np.bool_)
        self._k = 0  # steps seen by the success test
        self._apart_from = np.zeros((n, 3))  # step and position where the current run apart began
        self._loss = np.full((n, 3), np.nan)  # the same for the run that failed the agent
        self._d2_ind = np.full(n, np.inf)  # per agent: smallest squared distance to another agent
        self._d_obs = np.full(n, np.inf)  # per agent: smallest signed distance to an obstacle
        if self.mission:
            self._track_mission(x, nb, None)
            self._failed |= self._apart > 0  # "from the beginning": with the IU at k = 0
            self._loss[self._failed] = self._apart_from[self._failed]
            self._k = 0  # act(k = 0) sees the same state again

    # ------------------------------------------------------------------ step

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x = np.asarray(obs.positions, dtype=np.float64)
        n = self.n
        nb = self._neighbours(x)  # (order, start, end, indices, dist2)
        r2 = p.r * p.r
        iu = self.iu
        theta_d = self._theta_d(x) if self.has_info else 0.0
        # what each agent reads of its neighbours: the true states (ideal network), or its own
        # picture of them, received over the network (networked.py)
        seen = nb
        theta_s, layers_s, avoiding_s, number_s, pos_s, ident = (self.theta, self.layers, self.avoiding,
                                                                 self.theta_num, x, None)
        if obs.view is None:
            iu_nb = np.zeros(n, dtype=np.bool_)
            if iu >= 0:
                row = slice(nb[1][iu], nb[2][iu])
                iu_nb[nb[3][row][nb[4][row] <= r2]] = True
        else:
            if iu >= 0 and p.layer_update == "eq4":
                raise ConfigError(f"{self.name}: layer_update = eq4 takes the layers from the whole neighbour graph "
                                  "each step, which no agent holds on a network; use eq5 (the layers travel from "
                                  "neighbour to neighbour) or the ideal network")
            own = {"theta": self.theta, "avoiding": self.avoiding, "layers": self.layers, "number": self.theta_num}
            pic = pictures(obs, x, own, self.radius, r2, self.box, p.wrap_neighbours, iu)
            seen, iu_nb, ident = pic.nb, pic.iu_nb, pic.ident
            theta_s, layers_s, avoiding_s, number_s, pos_s = pic.theta, pic.layers, pic.avoiding, pic.number, pic.pos

        # eq. (6) noise; the information UAV flies its reference heading (the kernel skips it)
        noise = rng.uniform(-p.eta / 2, p.eta / 2, n) if p.eta > 0 else _NO_NOISE
        theta_g = np.empty(n)
        r2_list = np.inf if self.radius <= p.r else r2  # inf: no entry lies beyond r
        args = (self.code, *seen, r2_list, theta_s, self.theta_g, layers_s, avoiding_s, iu, iu_nb, theta_d,
                p.p1, p.p2, p.nei_weight, p.k_alpha, p.k_beta, p.k_gamma, p.info_weight, noise, theta_g,
                _IVEM_RULES[p.ivem_rule], math.pi if p.ivem_range == "unsigned" else 0.0, p.ivem_self)
        num = None if self.theta_num is None else np.empty(n)
        if ident is not None:  # ghost slots: the agent each stands for
            K.genuine_heading(*args, number_s, num, ident)
        elif num is None:
            K.genuine_heading(*args)
        else:
            K.genuine_heading(*args, number_s, num)

        theta = theta_g
        avoiding = np.zeros(n, dtype=np.bool_)
        dist = None
        if self.geom is not None:
            tested = theta_g if p.trigger_heading == "new" else self.theta_g
            avoiding, theta_obs, dist = avoidance(self.geom, x, tested, self.theta, p.r_avoid, p.theta_obstruct)
            theta = np.where(avoiding, theta_obs, theta_g)
            if num is not None:
                num = np.where(avoiding, theta_obs, num)  # the tangent's angle (eq. 22), as computed

        att = rep = _NO_FORCE
        if p.c_rep or p.c_att:
            att = np.empty((n, 2))
            rep = np.empty((n, 2))
            K.attraction_repulsion(*seen, pos_s, self.box, p.wrap_neighbours, p.r_rep, p.r_att, iu, att, rep)
        v = np.empty((n, 2))
        K.velocity(theta, avoiding, att, rep, p.c_align * p.v0, p.c_rep, p.c_att, p.v_max,
                   p.avoid_velocity == "tangent", v)

        if self.mission:
            self._track_mission(x, nb, dist)
        if iu >= 0:
            nxt = np.empty_like(self.layers)
            if p.layer_update == "eq5":
                K.next_layers(*seen, r2, layers_s, iu, nxt)
            else:
                K.bfs_layers(*nb, r2, iu, nxt)
            self.layers = nxt
        self.theta, self.theta_g, self.avoiding = theta, theta_g, avoiding
        if num is not None:
            self.theta_num = num

        self.deg_series.append(self._deg_con())
        self._streak = self._streak + 1 if self.deg_series[-1] >= p.deg_con_d else 0
        # what every agent sends with its state (read back by the others over a network)
        publish = {THETA: theta, AVOIDING: avoiding}
        if iu >= 0:
            publish[LAYER] = self.layers
        if num is not None:
            publish[NUMBER] = num
        info: dict[str, Any] = {"publish": publish}
        if p.stop_at_convergence and self._streak >= p.converge_hold:
            info["done"] = True
        return v, info

    # ------------------------------------------------------------------ results

    def summary(self) -> dict[str, float]:
        """k_con (eq. 27; +inf if not reached within the run), converged (Deg_con against the reference >=
        Deg_con^d at the end, 0/1), deg_con_final; in open worlds with an information UAV
        also P_s [%] (eq. 32), D_obs and D_ind [m] (Sec. 3.2)."""
        p = self.params
        series = np.asarray(self.deg_series)
        k = len(series) - self._streak if self._streak else float("inf")  # inf: not within the run
        ref = self.theta[self.iu] if self.has_info else p.reference
        out = {
            "k_con": float(k),
            "converged": float(deg_con(self.theta, ref, p.deg_con_norm) >= p.deg_con_d),
            "deg_con_final": float(series[-1]),
        }
        if self.has_info:
            out["info_uav"] = float(self.iu)
        if self.mission:
            # "to the end": with the IU at the last step seen
            out["P_s"] = 100.0 * float(np.mean(~(self._failed | (self._apart > 0))))
            ok = ~(self._failed | (self._apart > 0))
            take = ok if p.safety_agents == "successful" else np.ones(self.n, dtype=np.bool_)
            out["D_obs"] = float(self._d_obs[take].min()) if take.any() else float("nan")
            out["D_ind"] = float(np.sqrt(self._d2_ind[take].min())) if take.any() else float("nan")
        return out

    def losses(self) -> dict[str, np.ndarray]:
        """Diagnostics of the success test (eq. 32) of a mission run: the agents that failed.

        For each: ``agent`` (index), ``step`` and ``x``, ``y`` [m] where the run of steps apart
        from the information UAV that failed it began (step 0: not with it at the start), and
        ``apart_at_end`` (still apart at the last step, i.e. it never rejoined). Not a metric:
        benchmarks/hwvem_tables.py --losses tallies these by the nearest obstacle.
        """
        if not self.mission:
            raise ValueError("losses() needs a mission run (open world with an information UAV)")
        loss = self._loss.copy()
        at_end = self._apart > 0
        late = at_end & np.isnan(loss[:, 0])  # apart at the end within follow_gap: fails "to the end"
        loss[late] = self._apart_from[late]
        agent = np.flatnonzero(~np.isnan(loss[:, 0]))
        return {"agent": agent, "step": loss[agent, 0].astype(np.int64), "x": loss[agent, 1],
                "y": loss[agent, 2], "apart_at_end": at_end[agent]}

    # ------------------------------------------------------------------ helpers

    def _neighbours(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        """Neighbour list of ``x`` in the reusable buffers: ``(order, start, end, indices,
        dist2)`` with the neighbours of ``i`` in ``indices[start[i]:end[i]]``."""
        wrap_nb = self.params.wrap_neighbours
        order, start, end, total = K.neighbour_csr(x, self.radius, self.box, wrap_nb, self._idx, self._d2)
        if total > len(self._idx):
            self._idx = np.empty(int(total * 1.25) + 64, dtype=np.int64)
            self._d2 = np.empty(len(self._idx), dtype=np.float64)
            order, start, end, total = K.neighbour_csr(x, self.radius, self.box, wrap_nb, self._idx, self._d2)
        return order, start, end, self._idx[:total], self._d2[:total]

    def _theta_d(self, x: np.ndarray) -> float:
        """Reference heading for the next step: fixed in a periodic world, else the path's."""
        if self.path is None:
            return float(wrap(self.params.reference))
        th, self.s_path = pursue(self.path, x[self.iu], self.s_path, self.params.lookahead)
        return th

    def _deg_con(self) -> float:
        """Deg_con (eq. 28) against the information UAV's heading, or the consensus direction."""
        ref = float(self.theta[self.iu]) if self.has_info else 0.0
        return K.consistency(self.theta, ref, not self.has_info, _NORMS[self.params.deg_con_norm])

    def _track_mission(self, x: np.ndarray, nb: tuple, dist: np.ndarray | None) -> None:
        """Per-step bookkeeping of the success test and the safety distances."""
        p = self.params
        if p.follow_test == "component":
            comp = np.empty(self.n, dtype=np.int64)
            K.bfs_layers(*nb, p.r * p.r, self.iu, comp)
            near = comp < K.NO_LAYER
        else:
            near = np.sum((x - x[self.iu]) ** 2, axis=1) <= p.follow_radius**2
        self._apart = np.where(near, 0, self._apart + 1)
        began = self._apart == 1
        self._apart_from[began, 0] = self._k
        self._apart_from[began, 1:] = x[began]
        failed = self._failed | (self._apart > p.follow_gap)
        self._loss[failed & ~self._failed] = self._apart_from[failed & ~self._failed]
        self._failed = failed
        counted = self._k >= p.safety_from
        self._k += 1
        if not counted:
            return
        _, start, end, _, d2 = nb
        if len(d2):
            rows = np.argsort(start, kind="stable")  # the rows are contiguous, in this order
            owner = np.repeat(rows, (end - start)[rows])
            np.minimum.at(self._d2_ind, owner, d2)
        if self.obstacles is not None:
            if dist is None:
                dist = signed_distance(self.obstacles, x)
            np.minimum(self._d_obs, dist, out=self._d_obs)


def info_uav_index(scenario: Scenario, positions: np.ndarray) -> int:
    """The information UAV: the agent nearest to the lower-left corner of a periodic world
    (Sec. 3.1), else nearest to the start of the scene's path (or to the spawn centre)."""
    x = np.asarray(positions, dtype=np.float64)
    if scenario.periodic:
        target = np.array(scenario.bounds[:2])
    elif scenario.path:
        target = np.array(scenario.path[0])
    else:
        s = scenario.swarm.spawn
        target = np.array([(s[0] + s[2]) / 2, (s[1] + s[3]) / 2])
    return int(np.argmin(np.sum((x - target) ** 2, axis=1)))
