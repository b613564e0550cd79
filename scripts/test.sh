#!/usr/bin/env bash
# Set up a fresh clone and run the whole test suite: the README's test command, and what CI
# runs (.ci/run). Installs everything the tests use, from the package registries only:
#   - Debian's chromium, for the browser test of the HTML report (when apt-get is available);
#   - a virtual environment .venv with swarmnav and its test extras.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  echo "installing chromium (Debian) for the report browser test..."
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >/dev/null
fi

python3 -m venv .venv
.venv/bin/pip install -q --upgrade pip
.venv/bin/pip install -q -e '.[test]'
exec .venv/bin/python -m pytest "$@"
