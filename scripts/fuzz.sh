#!/usr/bin/env bash
# Runs one target of the seeded mutation fuzzer (tests/examples/fuzz.rs) for SECONDS of wall
# time, restarting it with the next seed whenever the process dies (an allocation failure
# under the memory cap, a stack overflow, a hang past the per-input timeout); the input
# that was running is kept under OUT/aborts/. One JSON line per run goes to OUT/runs.jsonl.
#
#   scripts/fuzz.sh TARGET SECONDS [FIRST_SEED] [OUT] [BINARY]
#
# BINARY defaults to the example built in the dev profile:
#   cargo build -p probe-tests --example fuzz
set -u
target=$1
seconds=$2
seed=${3:-1}
out=${4:-target/fuzz/$target}
binary=${5:-${CARGO_TARGET_DIR:-target}/debug/examples/fuzz}
mkdir -p "$out"
# A runaway allocation fails inside the fuzzer instead of taking the machine's memory.
ulimit -v $((6 * 1024 * 1024))
start=$(date +%s)
while true; do
  left=$((seconds - ($(date +%s) - start)))
  [ "$left" -le 0 ] && break
  "$binary" "$target" "$left" "$seed" "$out" >>"$out/runs.jsonl" 2>>"$out/log.txt"
  status=$?
  if [ "$status" -ne 0 ]; then
    echo "run with seed $seed ended with status $status" >>"$out/log.txt"
    if [ -d "$out/current" ]; then
      mkdir -p "$out/aborts"
      mv "$out/current" "$out/aborts/seed-$seed-status-$status"
    fi
  fi
  seed=$((seed + 1))
done
