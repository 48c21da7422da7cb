#!/usr/bin/env bash
# saulctl tune report's page in a real browser (Debian's chromium, headless and offline, as plot_browser.sh): a
# 1 kHz trace with an excitation draws its four charts (step response, gain, spectra, the trace) without a script
# error; a 10 Hz capture draws only the trace and says why the rest is not drawn.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

source "$(dirname "$0")/browser.bash"
need_browser

/usr/bin/python3 - "$root/tests/tune" "$out/run.csv" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import traces
cols = traces.trace(0.4, 4.0, "prbs", seconds=20, sine_hz=17.3, sine_dps=4.0)
cols["excite"][:5000] = 0  # the first 5 s without excitation
traces.write_csv(sys.argv[2], cols)
PY
"$saulctl" tune report "$out/run.csv" -o "$out/run.html" >/dev/null 2>"$out/err"
check "tune report -o writes the page and says where" grep -q "the page is $out/run.html" "$out/err"
dom "file://$out/run.html" >"$out/run.dom"
tag=$(grep -o '<html[^>]*>' "$out/run.dom" | head -n 1)
echo "  run.html: $tag"
check "the page loads without a script error" test "$(attr "$tag" data-tune-errors)" = 0
check "... and draws its 4 charts" test "$(attr "$tag" data-tune-names)" = "step,gain,spectra,series"
check "... under the summary's figures (overshoot, the oscillation at 17 Hz)" \
  bash -c "grep -q 'overshoot' '$out/run.dom' && grep -q 'oscillation   17' '$out/run.dom'"

"$saulctl" tune report "$root/captures/robot_bus.log" -o "$out/bus.html" >/dev/null 2>&1
dom "file://$out/bus.html" >"$out/bus.dom"
tag=$(grep -o '<html[^>]*>' "$out/bus.dom" | head -n 1)
echo "  bus.html: $tag"
check "10 Hz telemetry: no script error, only the trace drawn" \
  bash -c "test '$(attr "$tag" data-tune-errors)' = 0 && test '$(attr "$tag" data-tune-names)' = series"
check "... and the page says why the step response is not drawn" \
  grep -q 'Not drawn: the trace is sampled at 10 Hz' "$out/bus.dom"

echo "$fails failed"
[ "$fails" -eq 0 ]
