#!/usr/bin/env bash
# Quick start: build, simulate the default scenario (polar-crossing.toml: 68° N
# over the North Pole to 68° N, through both frame switches), run the live
# pipeline over iceoryx2 shared memory -- nav-daemon and the flight recorder as
# services, sensor-replay publishing the flight at 200x wall-clock speed --
# and evaluate the recorded live solution. Detailed output goes to files in
# out/quickstart/; the script ends with the accuracy table, the switch
# transients and whether the live solution is, bit for bit, what
# `nav-daemon batch` computes from the same log.
set -euo pipefail
cd "$(dirname "$0")/.."
scenario=${1:-config/scenarios/polar-crossing.toml}
speed=${SPEED:-200}
out=out/quickstart
prefix="quickstart_$$"
mkdir -p "$out"
# The recorder never overwrites a recording: this script's own one from an
# earlier run goes first.
rm -f "$out/live.navlog"
B=./target/release
pids=()
cleanup() { for p in "${pids[@]:-}"; do [ -n "$p" ] && kill -TERM "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

wait_for() { # file text seconds
  for _ in $(seq 1 $(( $3 * 10 ))); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  echo "timed out waiting for '$2' in $1" >&2; cat "$1" >&2; exit 1
}

echo "== building (release; the first build takes about 7 minutes on 2 cores)"
cargo build --release --bins
echo "== simulating $scenario into $out/flight.navlog"
$B/sensor-replay simulate --scenario "$scenario" --out "$out/flight.navlog" --seed 1 2>&1 | tail -1
# The daemon's settings describe the IMU installed, as on an aircraft: the
# shipped configuration (written for a 200 Hz IMU), on a prefix of its own,
# with [live] imu_rate_hz set to the rate of the IMU this flight simulates
# (the scenario's [imu] rate_hz; polar-crossing's is 100 Hz). The daemon
# would otherwise say, rightly, that the stream is not the configured rate.
imu_rate_hz=$(awk '/^\[/ { in_imu = ($0 ~ /^\[imu\][ \t]*(#.*)?$/); next }
  in_imu && /^[ \t]*rate_hz[ \t]*=/ { sub(/^[^=]*=[ \t]*/, ""); sub(/[ \t]*#.*$/, ""); print; exit }' "$scenario")
sed -e "s/^prefix = .*/prefix = \"$prefix\"/" \
    -e "s/^imu_rate_hz = .*/imu_rate_hz = ${imu_rate_hz:-200.0}/" config/nav-daemon.toml > "$out/nav-daemon.toml"
$B/nav-daemon --check-config "$out/nav-daemon.toml" > /dev/null
echo "== the daemon's settings: config/nav-daemon.toml for this flight's ${imu_rate_hz:-200.0} Hz IMU ($out/nav-daemon.toml)"

echo "== live: nav-daemon and the flight recorder as services on $prefix/..., the flight replayed at ${speed}x"
$B/nav-daemon --config "$out/nav-daemon.toml" > "$out/daemon.log" 2>&1 & pids+=($!)
wait_for "$out/daemon.log" "services open" 30
$B/sensor-replay record --prefix "$prefix" --out "$out/live.navlog" > "$out/record.log" 2>&1 & pids+=($!)
wait_for "$out/record.log" "subscribed" 30
$B/sensor-replay play "$out/flight.navlog" --speed "$speed" --prefix "$prefix"
# Stopped as systemd stops the units: the daemon first, so that the
# recording ends with its last solution and final status.
kill -TERM "${pids[0]}"; wait "${pids[0]}" || true
kill -TERM "${pids[1]}"; wait "${pids[1]}" || true
pids=()
echo "daemon ($out/daemon.log):"
grep -E "clean exit|frame switch|the IMU stream runs at" "$out/daemon.log" | sed -e 's/\x1b\[[0-9;]*m//g' -e 's/^/  /'
echo "recorder: $(tail -1 "$out/record.log")"

echo "== evaluating (eval's full report: $out/eval.txt; figures and summary.md in $out/)"
$B/sensor-replay export "$out/live.navlog" --solution-csv "$out/live.csv" > "$out/export.log" 2>&1 ||
  { cat "$out/export.log" >&2; exit 1; }
# The transient of a switch is what it changes: the same log navigated
# without that switch is the reference (the experiments' measure). A
# geographic-only run cannot cross the pole, so the reference stays in the
# grid frame from the first sample (--force-switch 0: one switch, at once).
$B/nav-daemon batch --config "$out/nav-daemon.toml" --log "$out/flight.navlog" --force-switch 0 --out "$out/grid-throughout.csv" > "$out/batch-grid.log" 2>&1 ||
  { cat "$out/batch-grid.log" >&2; exit 1; }
$B/sensor-replay eval --log "$out/flight.navlog" --solution "$out/live.csv" --compare "$out/grid-throughout.csv" --out "$out" > "$out/eval.txt"
$B/nav-daemon batch --config "$out/nav-daemon.toml" --log "$out/flight.navlog" --out "$out/batch.csv" > "$out/batch.log" 2>&1 ||
  { cat "$out/batch.log" >&2; exit 1; }
if cmp -s "$out/live.csv" "$out/batch.csv"; then
  verdict="live equals batch: the live solution is, bit for bit, what nav-daemon batch computes from the same log ($(($(wc -l < "$out/live.csv") - 1)) rows)"
  rm "$out/batch.csv"
else
  verdict="live and batch solutions DIFFER: cmp $out/live.csv $out/batch.csv"
fi
echo "== outputs in $out/ (batch mode: nav-daemon batch --log $out/flight.navlog --out solution.csv)"

# Last, what the run shows: the live solution's accuracy against the truth,
# each switch's transient against the run without it, and the verdict.
# (Tables of eval's report: the first accuracy table and the transients.)
echo
echo "== accuracy of the live solution against the truth ($out/summary.md)"
awk '/^## Accuracy: .*\(solution: / { on = 1 } on && /^\|/ { print; seen = 1; next } on && seen { exit }' "$out/eval.txt"
echo
echo "== each switch's transient: the live solution against the same log navigated without it"
transients=$(awk '/^### Switch transients/ { on = 1; next } on && /^\|/ { print; seen = 1; next } on && seen { exit }' "$out/eval.txt")
echo "${transients:-no frame switch in this flight}"
echo
echo "== $verdict"
case "$verdict" in live\ equals*) ;; *) exit 1 ;; esac
