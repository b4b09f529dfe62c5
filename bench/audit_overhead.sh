#!/usr/bin/env bash
# Audit overhead (docs/farm.md "Audit"): the same job on two farms of this machine, each a
# coordinator with two single-threaded workers, one with --audit-fraction 0 and one with the
# default 0.02, alternately, several times (both farms stay up; the idle one only long-polls).
# A warm-up job on each first pays the audited farm's probation (each worker's first unit).
# Prints each run's wall clock and the median ratio audited / unaudited (the goal: <= 1.03).
#
# The scene is rendered in units of [spp per unit] samples (default 4: 64 units a job), so that
# 2 % is about one audited unit a job.
#
#   bash bench/audit_overhead.sh [runs] [scene] [spp] [WxH] [fraction] [spp per unit]
set -euo pipefail
RUNS=${1:-5}
SCENE=${2:-scenes/cornell-seed.json}
SPP=${3:-256}
RES=${4:-256x256}
FRACTION=${5:-0.02}
PER_UNIT=${6:-4}
BIN=${BUILD_DIR:-build}
run=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$run"; }
trap cleanup EXIT

farm() {  # farm NAME FRACTION: a coordinator and two workers; its address in $run/NAME.port
  "$BIN/coordinator/lensfarm-coordinator" --listen 127.0.0.1:0 --port-file "$run/$1.port" --log-level warn \
    --audit-fraction "$2" 2>"$run/$1.log" &
  pids+=($!)
  for _ in $(seq 300); do [ -s "$run/$1.port" ] && break; sleep 0.1; done
  for w in 1 2; do
    "$BIN/worker/lensfarm-worker" --coordinator "$(cat "$run/$1.port")" --threads 1 --name "$1-$w" \
      --cache-dir "$run/cache-$1" --log-level warn 2>"$run/$1-w$w.log" &
    pids+=($!)
  done
}
now() { date +%s.%N; }
job() {  # job NAME: seconds from submit to done
  local address t0 id
  address=$(cat "$run/$1.port")
  t0=$(now)
  id=$("$BIN/client/lensfarm" submit "$SCENE" --spp "$SPP" --resolution "$RES" --coordinator "$address")
  "$BIN/client/lensfarm" watch "$id" --coordinator "$address" >/dev/null 2>&1
  awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }'
}

# The scene with its unit size, beside its meshes.
mkdir "$run/scene"
ln -s "$(cd "$(dirname "$SCENE")" && pwd)/meshes" "$run/scene/meshes"
sed "s/\"render\": *{/\"render\": {\"samples_per_unit\": $PER_UNIT, /" "$SCENE" >"$run/scene/scene.json"
SCENE="$run/scene/scene.json"

farm plain 0
farm audited "$FRACTION"
echo "scene $SCENE, $RES, $SPP spp; audit fraction $FRACTION; machine: $(nproc) cores"
job plain >/dev/null
job audited >/dev/null
ratios=()
for i in $(seq "$RUNS"); do
  # Alternate which farm goes first, so that neither gains from the order.
  if [ $((i % 2)) -eq 1 ]; then a=$(job plain); b=$(job audited); else b=$(job audited); a=$(job plain); fi
  r=$(awk -v a="$a" -v b="$b" 'BEGIN { print b / a }')
  ratios+=("$r")
  printf "run %d: without audit %.2f s, with %.2f s, ratio %.3f\n" "$i" "$a" "$b" "$r"
done
passed=0
for j in $(seq 2 $((RUNS + 1))); do
  n=$("$BIN/client/lensfarm" status "job-$j" --coordinator "$(cat "$run/audited.port")" |
    sed -n 's/.*audit: *\([0-9]*\) passed.*/\1/p')
  passed=$((passed + ${n:-0}))
done
echo "audits passed in the $RUNS measured audited jobs: $passed"
median=$(printf "%s\n" "${ratios[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}')
printf "median audited / unaudited: %.3f\n" "$median"
