#!/usr/bin/env bash
# Quick start: build, simulate the default transpolar scenario, navigate it
# with nav-daemon in batch mode and print the accuracy summary.
set -euo pipefail
cd "$(dirname "$0")/.."
scenario=${1:-config/scenarios/transpolar.toml}
out=out/quickstart
mkdir -p "$out"
echo "== building (release)"
cargo build --release --bins
echo "== simulating $scenario"
./target/release/sensor-replay simulate --scenario "$scenario" --out "$out/flight.navlog" --seed 1
echo "== navigating: SINS + SRS/CNS/baro error-state filter, g/G frame switching"
./target/release/nav-daemon batch --log "$out/flight.navlog" --out "$out/solution.csv" --aids srs,cns,baro --progress 600
echo "== accuracy"
./target/release/sensor-replay eval --log "$out/flight.navlog" --solution "$out/solution.csv" --out "$out"
echo "== outputs in $out/"
