#!/usr/bin/env bash
# The main job on a machine with no robot: sets up, builds saulctl, starts the simulated SAUL-TEE (both boards'
# firmware on a physics model, exposed as a CANable2 on a pseudo-terminal), raises its speed cap to 50 % and arms it
# with the virtual button, puts it in balance mode and shows it balancing in `saulctl monitor`; then the tuning
# instrument: 20 s of the balance loop at 1 kHz with a 1-degree chirp on its setpoint (`saulctl tune record` on
# BALANCE's console) and what it says about the gains (`saulctl tune report`: step response, oscillation,
# saturation; build/demo-tune.html).
#   scripts/demo.sh                 20 s of live telemetry (SAUL_DEMO_SECONDS to change)
#   scripts/demo.sh decode FILE     any other saulctl command instead (e.g. decode captures/robot_bus.log)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
SAUL_SKIP_EMBEDDED=1 scripts/setup.sh
cmake --preset default -DSAUL_BUILD_TESTS=OFF -DSAUL_BUILD_BENCH=OFF >/dev/null
cmake --build --preset default --target saulctl
saulctl=build/saulctl/saulctl
if (($# > 0)); then
  exec "$saulctl" "$@"
fi

paths=build/sim.paths
rm -f "$paths"
"$saulctl" sim --quiet --paths-file "$paths" >build/sim.log 2>&1 &
sim=$!
trap 'kill $sim 2>/dev/null; wait $sim 2>/dev/null || true' EXIT
for _ in $(seq 100); do [[ -s $paths ]] && break; sleep 0.05; done
can=$(sed -n 's/^can=//p' "$paths")
control=$(sed -n 's/^control=//p' "$paths")
balance=$(sed -n 's/^balance=//p' "$paths")
echo "simulated robot: CAN on slcan:$can, control console $control (see build/sim.log)"

sleep 1                              # BALANCE reports itself upright to IO
# The speed cap, 10 % at power-on, raised while disarmed (10 % a step) to 50 %: BALANCE runs a test signal (the
# chirp below) only from there (docs/tuning.md).
for pct in 20 30 40 50; do "$saulctl" console "$balance" speed_limit "$pct" >/dev/null; done
echo "button down" >"$control"       # the arming button: held 3 s while upright
sleep 3.2
echo "button up" >"$control"
"$saulctl" mode balance --yes --link "slcan:$can"
"$saulctl" monitor --link "slcan:$can" --duration "${SAUL_DEMO_SECONDS:-20}s"
# 20 s: the step response's 8 s windows want 20 s or more (10 s gives 5 windows and rough figures: docs/tuning.md).
"$saulctl" tune record --console-balance "$balance" --duration 20s --excite chirp --amplitude 1 -o build/demo.trace
"$saulctl" tune report build/demo.trace -o build/demo-tune.html
