#!/usr/bin/env bash
# Set up (if needed) and run the server with the simulated rig: `scripts/serve.sh [viestac serve options]`.
# The first run installs the Python packages (about 90 s on a 2-core machine) and the browser
# client's npm packages; setup.sh says which step it is at. Later runs skip what is there.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/viestac ]; then
  echo "serve: first run: setting up (Python packages, the compiled core, the browser client; about 2 minutes)"
fi
bash scripts/setup.sh
echo "serve: starting the server (viestac serve $*); it prints the console's login link when ready"
exec .venv/bin/viestac serve "$@"
