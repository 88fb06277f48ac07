#!/usr/bin/env bash
# The live-node tests (pytest -m ros) ROUNDS times in a row while two CPU burners run: the flake check of
# docs/ros.md ("Live tests under load"). Each round's pytest output goes to OUT/round_NN.log, one line per
# round (time, passed, failed, seconds) to OUT/summary.txt; the exit status is the number of failed rounds
# (capped at 255).
#   bench/live_soak.sh [ROUNDS (20)] [OUT (out/live_soak)]      PYTHON=... to choose the interpreter
set -u
ROUNDS=${1:-20}
OUT=${2:-out/live_soak}
PYTHON=${PYTHON:-.venv/bin/python}
cd "$(dirname "$0")/.."
mkdir -p "$OUT"
burners=()
stop_burners() { for pid in "${burners[@]}"; do kill "$pid" 2>/dev/null; done; }
trap stop_burners EXIT
for _ in 1 2; do
    "$PYTHON" -c "while True: pass" &
    burners+=($!)
done
echo "burners: ${burners[*]} ($(nproc) cores); $ROUNDS rounds of pytest -m ros" | tee "$OUT/summary.txt"
failed_rounds=0
for round in $(seq 1 "$ROUNDS"); do
    log=$(printf "%s/round_%02d.log" "$OUT" "$round")
    start=$(date +%s)
    "$PYTHON" -m pytest -q -m ros test -p no:cacheprovider > "$log" 2>&1
    status=$?
    seconds=$(( $(date +%s) - start ))
    result=$(tail -n 1 "$log")
    [ "$status" -ne 0 ] && failed_rounds=$((failed_rounds + 1))
    printf "%s round %02d exit %d in %d s: %s\n" "$(date -u +%H:%M:%S)" "$round" "$status" "$seconds" "$result" \
        | tee -a "$OUT/summary.txt"
done
echo "failed rounds: $failed_rounds of $ROUNDS" | tee -a "$OUT/summary.txt"
exit $(( failed_rounds > 255 ? 255 : failed_rounds ))
