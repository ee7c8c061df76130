#!/usr/bin/env bash
# Set up (if needed) and run every test: lint and layer contracts, JS unit tests (node), the C#
# client's build and tests (Mono, NUnit; `N passed, N failed`), then the Python suite (pytest),
# which includes the real-server integration tests and the headless-Chromium browser tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --test
echo "== lint (ruff) and layers (import-linter, docs/architecture.md \"Layers\")"
.venv/bin/ruff check .
.venv/bin/lint-imports --no-cache
echo "== browser client unit tests (node --test)"
(cd clients/web && node --test --test-reporter=dot test/)
echo "== C# client (clients/unity: Mono build, NUnit 2.6 incl. live tests against viestac serve)"
bash clients/unity/build.sh
echo "== Python tests (pytest)"
# --durations=15: the slowest tests, for the wall time the README reports
exec .venv/bin/python -m pytest -q --durations=15 "$@"
