#!/usr/bin/env bash
# saulctl plot's interactive page in a real browser: Debian's chromium, headless and offline (no network, no
# component updates, a fresh profile), loads the page from the file and prints its DOM once loaded. The page
# marks on its <html> element the script errors it met, the charts it drew, each chart's time window and how many
# show their sample points. Expected values come from the captures: robot_bus.log (6 dashboard panels over
# 2.9499 s), and the same story repeated 20 times, 3 s apart (59.9499 s; 600 pitch points).
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

source "$(dirname "$0")/browser.bash"  # need_browser, dom URL, attr TAG NAME
need_browser
# html_tag URL: the <html> start tag of URL once loaded
html_tag() { dom "$1" | grep -o '<html[^>]*>' | head -n 1; }

"$saulctl" plot "$root/captures/robot_bus.log" -o "$out/run.html" 2>/dev/null
tag=$(html_tag "file://$out/run.html")
echo "  robot_bus.html: $tag"
check "the page loads without a script error" test "$(attr "$tag" data-plot-errors)" = 0
check "... and draws all 6 panels" test "$(attr "$tag" data-plot-panels)" = 6
check "... every panel over the whole run, 0 to 2.9499 s (lined up before any zoom)" \
  test "$(attr "$tag" data-plot-windows)" = "$(printf '[0,2.9499]%.0s,' 1 2 3 4 5 6 | sed 's/,$//; s/.*/[&]/')"
check "... with their points (30 to 74 points a panel are few enough for 1400 px)" \
  test "$(attr "$tag" data-plot-points)" = 6

python3 - "$root/captures/robot_bus.log" "$out/long.log" <<'EOF'
import sys
lines = [l for l in open(sys.argv[1]).read().splitlines() if l.strip()]
with open(sys.argv[2], "w") as f:
    for k in range(20):
        for l in lines:
            ts, rest = l.split(" ", 1)
            f.write("(%.6f) %s\n" % (float(ts.strip("()")) + 3.0 * k, rest))
EOF
"$saulctl" plot "$out/long.log" -o "$out/long.html" 2>/dev/null
tag=$(html_tag "file://$out/long.html")
echo "  long.html: $tag"
check "a 60 s run: no error, 6 panels, no sample points at full view (600 to 1480 points a panel)" \
  bash -c "test '$(attr "$tag" data-plot-errors)' = 0 && test '$(attr "$tag" data-plot-panels)' = 6 && test '$(attr "$tag" data-plot-points)' = 0"
tag=$(html_tag "file://$out/long.html#t=10,12")
echo "  long.html#t=10,12: $tag"
check "zoomed into 10..12 s on the first panel: every panel follows" \
  test "$(attr "$tag" data-plot-windows)" = "$(printf '[10,12]%.0s,' 1 2 3 4 5 6 | sed 's/,$//; s/.*/[&]/')"
check "... and shows its sample points (20 to 50 in the window)" test "$(attr "$tag" data-plot-points)" = 6
check "... without a script error" test "$(attr "$tag" data-plot-errors)" = 0

echo "$fails failed"
[ "$fails" -eq 0 ]
