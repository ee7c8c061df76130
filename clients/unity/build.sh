#!/usr/bin/env bash
# Builds the client core, the Unity adapters against the test-only UnityEngine stand-in, the
# samples, the console viewer and the tests with Mono (mcs, C# 7.2), then runs the tests with
# NUnit 2.6 (nunit-console) and prints a closing "N passed, N failed" line. Exit status 1 when a
# test failed or did not run. `--build-only` stops before the tests; `--no-live` skips the
# tests that start a server (category "live").
set -euo pipefail
cd "$(dirname "$0")"
out=.build
mkdir -p "$out"
nunit=/usr/lib/cli/nunit.framework-2.6.3/nunit.framework.dll
[ -f "$nunit" ] || nunit=$(ls /usr/lib/cli/nunit.framework-*/nunit.framework.dll | head -1)
mcs_() { mcs -langversion:7.2 -nologo -warnaserror+ -debug "$@"; }

mcs_ -target:library -out:$out/Viestac.Client.dll -r:System.Net.Http.dll -r:System.Numerics.dll Runtime/*.cs
mcs_ -target:library -out:$out/UnityEngine.dll Tests/StandIn/*.cs
mcs_ -target:library -out:$out/Viestac.Unity.dll -r:$out/Viestac.Client.dll -r:$out/UnityEngine.dll Runtime/Unity/*.cs
mcs_ -target:library -out:$out/Viestac.Samples.dll -r:$out/Viestac.Client.dll -r:$out/Viestac.Unity.dll -r:$out/UnityEngine.dll $(find Samples~ -name '*.cs')
mcs_ -target:exe -out:$out/ViestacConsole.exe -r:$out/Viestac.Client.dll -r:System.Net.Http.dll Tools~/ViestacConsole/*.cs
mcs_ -target:library -out:$out/Viestac.Client.Tests.dll -r:$out/Viestac.Client.dll -r:$nunit -r:System.Net.Http.dll Tests/*.cs
[ "${1:-}" = "--build-only" ] && { echo "built into clients/unity/$out"; exit 0; }

rm -f $out/TestResult.xml
args=(-nologo -xml=TestResult.xml)
[ "${1:-}" = "--no-live" ] && args+=(-exclude=live)
set +e
(cd $out && nunit-console "${args[@]}" Viestac.Client.Tests.dll)
status=$?
set -e
# NUnit 2's summary line is its own format: say it plainly for CI.
python3 - "$out/TestResult.xml" "$status" <<'PY'
import sys, xml.etree.ElementTree as ET
try:
    root = ET.parse(sys.argv[1]).getroot()
except (OSError, ET.ParseError):
    print("0 passed, 1 failed (no test results: nunit-console exited with %s)" % sys.argv[2]); sys.exit(1)
cases = [c for c in root.iter("test-case") if c.get("executed") == "True"]
failed = [c for c in cases if c.get("success") != "True"]
for c in failed:
    print("FAILED", c.get("name"))
print("%d passed, %d failed" % (len(cases) - len(failed), len(failed)))
sys.exit(1 if failed or int(sys.argv[2]) != 0 else 0)
PY
