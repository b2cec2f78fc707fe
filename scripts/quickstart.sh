#!/usr/bin/env bash
# Quick start: build, simulate the default transpolar scenario, run the live
# pipeline over iceoryx2 shared memory -- nav-daemon and the flight recorder as
# services, sensor-replay publishing the flight at 50x wall-clock speed -- and
# print the accuracy summary of the recorded live solution.
set -euo pipefail
cd "$(dirname "$0")/.."
scenario=${1:-config/scenarios/transpolar.toml}
speed=${SPEED:-50}
out=out/quickstart
prefix="quickstart_$$"
mkdir -p "$out"
B=./target/release
pids=()
cleanup() { for p in "${pids[@]:-}"; do [ -n "$p" ] && kill -TERM "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

wait_for() { # file text seconds
  for _ in $(seq 1 $(( $3 * 10 ))); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  echo "timed out waiting for '$2' in $1" >&2; cat "$1" >&2; exit 1
}

echo "== building (release)"
cargo build --release --bins
echo "== simulating $scenario"
$B/sensor-replay simulate --scenario "$scenario" --out "$out/flight.navlog" --seed 1
printf 'prefix = "%s"\n' "$prefix" > "$out/nav-daemon.toml"

echo "== starting nav-daemon and the flight recorder (services $prefix/...)"
$B/nav-daemon --config "$out/nav-daemon.toml" > "$out/daemon.log" 2>&1 & pids+=($!)
wait_for "$out/daemon.log" "services open" 30
$B/sensor-replay record --prefix "$prefix" --out "$out/live.navlog" > "$out/record.log" 2>&1 & pids+=($!)
wait_for "$out/record.log" "subscribed" 30

echo "== replaying the flight at ${speed}x over iceoryx2"
$B/sensor-replay play "$out/flight.navlog" --speed "$speed" --prefix "$prefix"

echo "== stopping the daemon and the recorder"
kill -TERM "${pids[0]}"; wait "${pids[0]}" || true
kill -TERM "${pids[1]}"; wait "${pids[1]}" || true
pids=()
grep -E "clean exit|frame switch" "$out/daemon.log" | sed 's/\x1b\[[0-9;]*m//g' | tail -3
tail -1 "$out/record.log"

echo "== accuracy of the live solution"
$B/sensor-replay export "$out/live.navlog" --solution-csv "$out/live.csv"
$B/sensor-replay eval --log "$out/flight.navlog" --solution "$out/live.csv" --out "$out"
echo "== outputs in $out/ (batch mode: nav-daemon batch --log $out/flight.navlog --out solution.csv)"
