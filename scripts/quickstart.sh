#!/usr/bin/env bash
# Quick start: build, simulate the default scenario (polar-crossing.toml: 68° N
# over the North Pole to 68° N, through both frame switches), run the live
# pipeline over iceoryx2 shared memory -- nav-daemon and the flight recorder as
# services, sensor-replay publishing the flight at 200x wall-clock speed --
# print the accuracy summary of the recorded live solution, and check that it
# is, bit for bit, what `nav-daemon batch` computes from the same log.
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

echo "== building (release)"
cargo build --release --bins
echo "== simulating $scenario"
$B/sensor-replay simulate --scenario "$scenario" --out "$out/flight.navlog" --seed 1
# The shipped configuration, on a prefix of its own.
sed "s/^prefix = .*/prefix = \"$prefix\"/" config/nav-daemon.toml > "$out/nav-daemon.toml"

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

echo "== accuracy of the live solution, and its switch transients against a never-switching run"
$B/sensor-replay export "$out/live.navlog" --solution-csv "$out/live.csv"
# The transient of a switch is what it changes: the same log navigated
# without that switch is the reference (the experiments' measure). A
# geographic-only run cannot cross the pole, so the reference stays in the
# grid frame from the first sample (--force-switch 0: one switch, at once).
$B/nav-daemon batch --config "$out/nav-daemon.toml" --log "$out/flight.navlog" --force-switch 0 --out "$out/grid-throughout.csv" 2>&1 | grep -E "^batch:"
$B/sensor-replay eval --log "$out/flight.navlog" --solution "$out/live.csv" --compare "$out/grid-throughout.csv" --out "$out"

echo "== the live solution against batch on the same log"
$B/nav-daemon batch --config "$out/nav-daemon.toml" --log "$out/flight.navlog" --out "$out/batch.csv" 2>&1 | grep -E "^batch:"
if cmp -s "$out/live.csv" "$out/batch.csv"; then
  echo "live and batch solutions are identical ($(($(wc -l < "$out/live.csv") - 1)) rows)"
  rm "$out/batch.csv"
else
  echo "live and batch solutions DIFFER: cmp $out/live.csv $out/batch.csv" >&2
  exit 1
fi
echo "== outputs in $out/ (batch mode: nav-daemon batch --log $out/flight.navlog --out solution.csv)"
