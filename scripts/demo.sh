#!/usr/bin/env bash
# The main job, on a farm of one machine: a coordinator and two workers on localhost, the seed
# scene submitted, watched and downloaded into out/, then every process started here stopped.
set -euo pipefail
BUILD_DIR=${BUILD_DIR:-build}
SCENE=${SCENE:-scenes/cornell-seed.json}
OUT=${OUT:-out}
name=$(basename "$SCENE" .json)
bin="$BUILD_DIR"
mkdir -p "$OUT"
run=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  rm -rf "$run"
}
trap cleanup EXIT

"$bin/coordinator/lensfarm-coordinator" --listen 127.0.0.1:0 --port-file "$run/port" 2> "$run/coordinator.log" &
pids+=($!)
for _ in $(seq 300); do [ -s "$run/port" ] && break; sleep 0.1; done
[ -s "$run/port" ] || { cat "$run/coordinator.log"; echo "demo: the coordinator did not start" >&2; exit 1; }
export LENSFARM_COORDINATOR=$(cat "$run/port")
echo "demo: coordinator at $LENSFARM_COORDINATOR"

threads=$(( $(nproc) > 1 ? $(nproc) / 2 : 1 ))
for w in 1 2; do
  "$bin/worker/lensfarm-worker" --threads "$threads" --name "demo-worker-$w" --cache-dir "$run/cache-$w" \
    2> "$run/worker-$w.log" &
  pids+=($!)
done

job=$("$bin/client/lensfarm" submit "$SCENE")
echo "demo: submitted $SCENE as $job"
"$bin/client/lensfarm" watch "$job"
"$bin/client/lensfarm" download "$job" -o "$OUT/$name.exr" -o "$OUT/$name.png"
"$bin/client/lensfarm" status "$job"
"$bin/client/lensfarm" workers
