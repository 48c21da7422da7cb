# Sourced by the tests that load a saulctl page in a real browser (plot_browser.sh, tune_browser.sh); not a test.
# Debian's chromium, headless and offline (no network, no component updates, a fresh profile under $out).
#   need_browser            sets $browser, or prints the failure and exits 1 when chromium is not installed
#   dom URL                 the page's DOM once loaded, in a window 1400 px wide
#   attr TAG NAME           an attribute's value in a tag
need_browser() {
  browser=$(command -v chromium || command -v chromium-browser || true)
  if [ -z "$browser" ]; then
    echo "FAIL chromium is not installed: scripts/setup.sh installs it (Debian's chromium)"
    echo "1 failed"
    exit 1
  fi
}
dom() {
  "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking --disable-component-update \
    --disable-sync --no-first-run --user-data-dir="$(mktemp -d -p "$out")" --window-size=1400,1000 \
    --virtual-time-budget=5000 --dump-dom "$1" 2>/dev/null
}
attr() { sed -n "s/.* $2=\"\\([^\"]*\\)\".*/\\1/p" <<<"$1"; }
