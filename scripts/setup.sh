#!/usr/bin/env bash
# Idempotent setup on Debian 12 (Python 3.11, Node 20): system packages, the Python venv in
# .venv, and the browser client's npm packages. `--test` adds what the tests need (Chromium for
# the browser tests, Mono and NUnit for the C# client, the test extras). Safe to run again: it
# skips what is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

want_test=0
[ "${1:-}" = "--test" ] && want_test=1

apt_packages=()
python3 -c 'import venv, ensurepip' 2>/dev/null || apt_packages+=(python3-venv)
command -v npm >/dev/null || apt_packages+=(npm)
# gcc/make build the device firmware core that the emulators of the simulated rig run; gcc and
# Python's headers build the compiled haptic core (server/core/haptics/_chaptics.c, setup.py).
command -v gcc >/dev/null || apt_packages+=(gcc)
python3 -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
  || apt_packages+=(python3-dev)
command -v make >/dev/null || apt_packages+=(make)
if [ "$want_test" = 1 ]; then
  command -v chromium >/dev/null || apt_packages+=(chromium)
  command -v g++ >/dev/null || apt_packages+=(g++)  # compile-checks the ESP32 sketches
  # the audio tactors' tests: a real JACK server (dummy driver) and PortAudio for sounddevice
  command -v jackd >/dev/null || apt_packages+=(jackd2)
  ldconfig -p | grep -q libportaudio.so.2 || apt_packages+=(libportaudio2)
  # the C# (Unity-style) client: Mono's C# 7.2 compiler, the .NET Standard facades, NUnit 2.6
  command -v mcs >/dev/null || apt_packages+=(mono-mcs)
  [ -f /usr/lib/mono/4.5/Facades/netstandard.dll ] || apt_packages+=(mono-devel)
  command -v nunit-console >/dev/null || apt_packages+=(nunit-console)
  ls /usr/lib/cli/nunit.framework-*/nunit.framework.dll >/dev/null 2>&1 || apt_packages+=(libnunit-cil-dev)
fi
if [ "${#apt_packages[@]}" -gt 0 ]; then
  echo "setup: installing Debian packages: ${apt_packages[*]}"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${apt_packages[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  python3 -m venv .venv
fi
# Every extra (pyproject.toml): the analysis, the power analysis and the benches; the test extra
# brings them all. A rig that only serves needs none (`pip install -e .`).
extras="[analysis,power,bench]"
[ "$want_test" = 1 ] && extras="[test]"
stamp=".venv/.installed${extras}"
# setuptools notes, for the editable install of a project with several top-level packages
# (server, devices, scenarios), "Editable installation … be careful with folders in your working
# directory with the same name as your package": information, not a problem (those folders are
# the packages). It is the only line filtered out; pip's real warnings and errors still show.
export PYTHONWARNINGS="ignore:Editable installation"
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "setup: installing Python packages ${extras} into .venv (pip is quiet meanwhile: about 90 s the first time)"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -e ".${extras}"
  echo "setup: Python packages installed"
  touch "$stamp"
fi
# The compiled haptic core again when its C source changed since it was built (a pull, an edit):
# a stale build is not used (compiled.py warns and falls back to the Python reference).
core_so=$(ls server/core/haptics/_chaptics.*.so 2>/dev/null | head -n 1 || true)
if [ -z "$core_so" ] || [ server/core/haptics/_chaptics.c -nt "$core_so" ]; then
  echo "setup: building the compiled haptic core (about 20 s)"
  .venv/bin/python -m pip install -q --no-deps -e .
fi

# The firmware core the emulators run (rebuilt only when its C sources change).
.venv/bin/python -c "from devices.firmware_binding import ensure_library; ensure_library()"

if [ ! -d clients/web/node_modules ] || [ clients/web/package-lock.json -nt clients/web/node_modules ]; then
  echo "setup: installing the browser client's npm packages"
  (cd clients/web && npm ci --no-audit --no-fund --loglevel=error)
  touch clients/web/node_modules
fi
