"""Record and label the decision states of ``swarmnav llm bench`` (src/swarmnav/llm/data/decision_states.jsonl).

Run: ``python benchmarks/record_llm_states.py [--builds swarmnav:1-3,paper:1-10] [--out FILE]``.

HES flies each of the paper's four scenes (Table 5) with the rule policy, K = 1000 steps, in each
build (the default, and ``preset=paper``), and a probe source records what the planner saw: z(k)
(``DecisionState``, exactly what an LLM's prompt is built from), the rule's proposal a_k^rule and
the feasible set (the actions Pi_feas lets through), and labels it with the oracle's lookahead:
the objective J [m] of every feasible action and the best of them (``swarmnav.llm.labels``).
Recorded steps:

- the LLM call steps of eq. (20) (k = 0, 50, 100, ...: the states an LLM would be asked about);
- every step at which the rule proposed split or merge;
- steps where two or more actions are feasible: the first of each stretch of such steps, and
  every 10th step (1 s) within it (consecutive steps of a stretch are near repeats).

Deterministic, in portable numerics (docs/determinism.md): the same seeds give the same file on
any x86-64 machine, and ``swarmnav llm label`` re-creates every state from its run. Prints the states per scene and build and the
wall time.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

import swarmnav
from swarmnav.llm.labels import probe_run
from swarmnav.llm.prompt import ACTIONS

SCENES = ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal")
BUILDS = {"swarmnav": {}, "paper": {"preset": "paper"}}
OUT = Path(__file__).resolve().parents[1] / "src/swarmnav/llm/data/decision_states.jsonl"


class Selection:
    """The recorded steps (module docstring); called at every step, in order."""

    def __init__(self, interval: int, every: int = 10):
        self.interval, self.every = interval, every
        self.was_choice = False

    def __call__(self, step: int, z, rule: str, feasible: tuple) -> bool:
        choice = len(feasible) > 1
        first = choice and not self.was_choice
        self.was_choice = choice
        return step % self.interval == 0 or rule != "keep" or first or (choice and step % self.every == 0)


def seeds_of(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--builds", default="swarmnav:1-3,paper:1-10",
                    help="BUILD:SEEDS, comma-separated (builds: swarmnav, paper); the seeds fly every scene")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    # portable numerics (docs/determinism.md): the states re-create on any x86-64 machine, so
    # `swarmnav llm label` relabels them anywhere; the program runs again from the start once
    swarmnav.portable.restart()
    rows = []
    t_all = time.perf_counter()
    for item in args.builds.split(","):
        build, _, seeds = item.partition(":")
        params = BUILDS[build]
        for scene in SCENES:
            for seed in seeds_of(seeds or "1-3"):
                t0 = time.perf_counter()
                got = probe_run(scene, seed, steps=args.steps, params=params, select=Selection(50))
                rows += got
                print(f"{scene} {build} seed {seed}: {len(got)} states "
                      f"({sum(len(r['feasible']) > 1 for r in got)} with a choice), "
                      f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("".join(json.dumps(r, allow_nan=False) + "\n" for r in rows), encoding="utf-8")
    count = Counter(r["rule"] for r in rows)
    per = Counter((r["scene"], r["build"]) for r in rows)
    choice = Counter((r["scene"], r["build"]) for r in rows if len(r["feasible"]) > 1)
    print(f"wrote {len(rows)} states to {args.out} in {time.perf_counter() - t_all:.0f} s "
          f"(rule: {', '.join(f'{a} {count[a]}' for a in ACTIONS)})")
    for key in sorted(per):
        print(f"  {key[0]:<26} {key[1]:<9} {per[key]:>4} states, {choice[key]:>4} with a choice")
    return 0


if __name__ == "__main__":
    sys.exit(main())
