#!/usr/bin/env bash
# Farm efficiency: the same job rendered by `lensfarm render --threads 2` (one process) and by a
# coordinator with two single-threaded workers on this machine, alternately, several times.
# Prints each run's paths/s and the median ratio farm / in-process (the goal: >= 0.95).
#
#   bash bench/farm_efficiency.sh [runs] [scene] [spp] [WxH]
set -euo pipefail
RUNS=${1:-3}
SCENE=${2:-scenes/cornell-seed.json}
SPP=${3:-64}
RES=${4:-512x512}
BIN=${BUILD_DIR:-build}
W=${RES%x*}; H=${RES#*x}
PATHS=$(( W * H * SPP ))
run=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$run"; }
trap cleanup EXIT

"$BIN/coordinator/lensfarm-coordinator" --listen 127.0.0.1:0 --port-file "$run/port" --log-level warn 2>"$run/c.log" &
pids+=($!)
for _ in $(seq 300); do [ -s "$run/port" ] && break; sleep 0.1; done
export LENSFARM_COORDINATOR=$(cat "$run/port")
for w in 1 2; do
  "$BIN/worker/lensfarm-worker" --threads 1 --name "bench-$w" --cache-dir "$run/cache" --log-level warn 2>"$run/w$w.log" &
  pids+=($!)
done

now() { date +%s.%N; }
ratios=()
echo "scene $SCENE, $RES, $SPP spp: $PATHS paths per run; machine: $(nproc) cores"
for i in $(seq "$RUNS"); do
  t0=$(now)
  "$BIN/client/lensfarm" render "$SCENE" --spp "$SPP" --resolution "$RES" --threads 2 -q -o "$run/local.exr" >/dev/null 2>&1
  t1=$(now)
  job=$("$BIN/client/lensfarm" submit "$SCENE" --spp "$SPP" --resolution "$RES")
  "$BIN/client/lensfarm" watch "$job" >/dev/null 2>&1
  t2=$(now)
  read -r local_rate farm_rate ratio < <(awk -v p="$PATHS" -v a="$t0" -v b="$t1" -v c="$t2" \
    'BEGIN { l = p / (b - a); f = p / (c - b); print l, f, f / l }')
  ratios+=("$ratio")
  awk -v i="$i" -v l="$local_rate" -v f="$farm_rate" -v r="$ratio" 'BEGIN {
    printf "run %d: in-process %.3f M paths/s, farm (2 workers x 1 thread) %.3f M paths/s, ratio %.3f\n", i, l / 1e6, f / 1e6, r }'
done
median=$(printf "%s\n" "${ratios[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}')
printf "median farm / in-process: %.3f\n" "$median"
