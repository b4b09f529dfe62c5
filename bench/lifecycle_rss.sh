#!/usr/bin/env bash
# Coordinator memory with many finished jobs (docs/farm.md "Job life cycle"): N jobs of W x H at
# 1 spp rendered by one local worker, with --archive-after never (every film kept) and with the
# default (archived as each ends); prints the coordinator's resident memory (VmRSS) after each.
#
#   bash bench/lifecycle_rss.sh [jobs] [WxH] [state]   # "state": the coordinator keeps a --state-dir
set -euo pipefail
JOBS=${1:-50}
RES=${2:-800x800}
STATE=${3:-}
BIN=${BUILD_DIR:-build}
SCENE=scenes/cornell-seed.json
run=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$run"; }
trap cleanup EXIT

rss() { awk '/VmRSS/ { printf "%.0f MB", $2 / 1024 }' "/proc/$1/status"; }

measure() {  # $1: --archive-after value
  rm -rf "$run/port" "$run/state"
  local state=()
  [ -n "$STATE" ] && state=(--state-dir "$run/state")
  "$BIN/coordinator/lensfarm-coordinator" --listen 127.0.0.1:0 --port-file "$run/port" --log-level warn \
    --archive-after "$1" "${state[@]}" 2>"$run/c.log" &
  local coordinator=$!
  pids+=($coordinator)
  for _ in $(seq 300); do [ -s "$run/port" ] && break; sleep 0.1; done
  export LENSFARM_COORDINATOR=$(cat "$run/port")
  "$BIN/worker/lensfarm-worker" --threads 2 --name rss --cache-dir "$run/cache" --log-level warn 2>"$run/w.log" &
  local worker=$!
  pids+=($worker)
  local empty; empty=$(rss "$coordinator")
  local last
  for _ in $(seq "$JOBS"); do last=$("$BIN/client/lensfarm" submit "$SCENE" --spp 1 --resolution "$RES" 2>/dev/null); done
  "$BIN/client/lensfarm" watch "$last" >/dev/null 2>&1
  # Every job ended (one worker renders them in order); wait for the archiving of the last ones.
  if [ "$1" != never ]; then
    for _ in $(seq 600); do
      [ "$("$BIN/client/lensfarm" jobs --state done | grep -c '(archived)')" -ge "$JOBS" ] && break
      sleep 0.1
    done
  fi
  sleep 1
  local disk=""
  [ -n "$STATE" ] && disk=", state dir $(du -sm "$run/state" | cut -f1) MB"
  echo "--archive-after $1: $JOBS finished $RES jobs: coordinator VmRSS $(rss "$coordinator") (empty: $empty)$disk"
  kill -TERM "$worker" "$coordinator"; wait "$worker" "$coordinator" 2>/dev/null || true
}
measure never
measure 0
