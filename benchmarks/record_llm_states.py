"""Record the decision states of ``swarmnav llm bench`` (src/swarmnav/llm/data/decision_states.jsonl).

Run: ``python benchmarks/record_llm_states.py [--seeds 1-2] [--out FILE]``.

HES flies each of the paper's four scenes (Table 5) with the rule policy, K = 1000 steps, and a
decision source that wraps the rule records what the planner saw: z(k) (``DecisionState``,
exactly what an LLM's prompt is built from), the rule's proposal a_k^rule, and which actions
Pi_feas (``methods.hes.decision.project``) lets through. Recorded steps: the LLM call steps of
eq. (20) (k = 0, 50, 100, ...: the states an LLM would be asked about) and every step at which
the rule proposed split or merge (rare, and the states where a decision matters most).
Deterministic: the same seeds give the same file.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import swarmnav
from swarmnav.llm.prompt import ACTIONS, jsonable
from swarmnav.methods.hes.decision import RulePolicy, project
from swarmnav.methods.hes.method import Hes

SCENES = ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal")
OUT = Path(__file__).resolve().parents[1] / "src/swarmnav/llm/data/decision_states.jsonl"


class Recorder:
    """A decision source: the rule policy's proposal, with z(k) recorded on the chosen steps."""

    def __init__(self, rule: RulePolicy, interval: int):
        self.rule, self.interval = rule, interval
        self.rows: list[dict] = []

    def propose(self, z, step):
        prop = self.rule.propose(z, step)
        if step % self.interval == 0 or prop.action != "keep":
            self.rows.append({
                "k": int(step),
                "state": {k: jsonable(v, digits=None) for k, v in z.to_dict().items()},
                "rule": prop.action,
                "rule_reason": prop.reason,
                "feasible": [a for a in ACTIONS if project(a, z) == a],
            })
        return prop


def seeds_of(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-2", help="seeds per scene, e.g. 1-2 (default)")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    rows = []
    for scene in SCENES:
        for seed in seeds_of(args.seeds):
            hes = Hes()
            p = hes.params
            rec = Recorder(RulePolicy(p.paper.d_merge, p.paper.t_cd), p.llm_interval)
            swarmnav.run(hes.use_source(rec), scene, seed=seed, steps=args.steps)
            rows += [{"id": f"{scene}/s{seed}/k{r['k']}", "scene": scene, "seed": seed, **r} for r in rec.rows]
            print(f"{scene} seed {seed}: {len(rec.rows)} states", file=sys.stderr)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("".join(json.dumps(r, allow_nan=False) + "\n" for r in rows), encoding="utf-8")
    count = {a: sum(r["rule"] == a for r in rows) for a in ACTIONS}
    print(f"wrote {len(rows)} states to {args.out} (rule: {count})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
