#!/usr/bin/env bash
# Set up (if needed) and run the server with the simulated rig: `scripts/serve.sh [viestac serve options]`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/viestac serve "$@"
