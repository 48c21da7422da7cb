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
# with_axis_check PAGE COPY: COPY is PAGE with a script after the page's own that measures the time axis's labels
# as drawn (the boxes of their text) and marks on <html> how many labels run into the next one in their row
# (data-axis-overlaps: their text boxes less than 4 px apart) and the bottom panel's labels (data-axis-labels).
with_axis_check() {
  sed 's#</body>#<script>(function () {\
  var boxes = [].slice.call(document.querySelectorAll(".dygraph-axis-label-x")).map(function (e) {\
    var r = document.createRange(); r.selectNodeContents(e); var b = r.getBoundingClientRect();\
    return {l: b.left, r: b.right, t: Math.round(b.top), text: e.textContent};\
  }).sort(function (a, b) { return a.t - b.t || a.l - b.l; });\
  var n = 0, root = document.documentElement;\
  for (var i = 1; i < boxes.length; ++i) if (boxes[i].t === boxes[i - 1].t \&\& boxes[i].l < boxes[i - 1].r + 4) ++n;\
  var bottom = boxes.length ? boxes[boxes.length - 1].t : 0;\
  root.setAttribute("data-axis-overlaps", String(n));\
  root.setAttribute("data-axis-labels", boxes.filter(function (b) { return b.t === bottom; }).map(function (b) { return b.text; }).join(" "));\
})();</script></body>#' "$1" >"$2"
}
# axis_ok TAG: no label runs into the next, and the bottom axis has at least 4 labels, times of day one step apart
# that fall on multiples of that step (08:26:50.2, 08:26:50.4, not 08:26:50.201)
axis_ok() {
  test "$(attr "$1" data-axis-overlaps)" = 0 && python3 - "$(attr "$1" data-axis-labels)" <<'PY'
import sys
t = [int(h) * 3600 + int(m) * 60 + float(s) for h, m, s in (x.split(":") for x in sys.argv[1].split())]
step = round(t[1] - t[0], 9) if len(t) > 1 else 0
sys.exit(not (len(t) >= 4 and step > 0 and all(abs(b - a - step) < 1e-7 for a, b in zip(t, t[1:]))
              and all(abs(v / step - round(v / step)) < 1e-4 for v in t)))
PY
}

"$saulctl" plot "$root/captures/robot_bus.log" -o "$out/run.html" 2>/dev/null
tag=$(html_tag "file://$out/run.html")
echo "  robot_bus.html: $tag"
check "the page loads without a script error" test "$(attr "$tag" data-plot-errors)" = 0
check "... and draws all 6 panels" test "$(attr "$tag" data-plot-panels)" = 6
check "... every panel over the whole run, 0 to 2.9499 s (lined up before any zoom)" \
  test "$(attr "$tag" data-plot-windows)" = "$(printf '[0,2.9499]%.0s,' 1 2 3 4 5 6 | sed 's/,$//; s/.*/[&]/')"
check "... with their points (30 to 74 points a panel are few enough for 1400 px)" \
  test "$(attr "$tag" data-plot-points)" = 6
with_axis_check "$out/run.html" "$out/run_axis.html"
tag=$(html_tag "file://$out/run_axis.html")
echo "  time axis: $(attr "$tag" data-axis-labels) ($(attr "$tag" data-axis-overlaps) overlapping)"
check "... its time axis at 1400 px: labels apart, on round times of day one step apart" axis_ok "$tag"

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
with_axis_check "$out/long.html" "$out/long_axis.html"
for window in "" "#t=10,12" "#t=10,10.01"; do
  tag=$(html_tag "file://$out/long_axis.html$window")
  echo "  long.html$window time axis: $(attr "$tag" data-axis-labels) ($(attr "$tag" data-axis-overlaps) overlapping)"
  check "a 60 s run${window:+ zoomed to ${window#\#t=}}: the time axis's labels apart, on round times of day" axis_ok "$tag"
done

echo "$fails failed"
[ "$fails" -eq 0 ]
