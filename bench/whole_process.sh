#!/usr/bin/env bash
# Everything around the render (docs/performance.md): `lensfarm render` of a
# scene at 1080p and 1 spp, writing an EXR and a PNG, run N times. Prints, as medians over the
# runs: the whole-process wall time, the render time the renderer prints ("time:"), their
# difference, and each phase of the overhead from the command's own timings (LENSFARM_TIMINGS=1,
# client/render_command.cpp) plus process start (exec to the command) and exit (the command's
# end to the shell seeing the process gone).
#
# With several binaries they are run alternately (A B A B ...), so that a noisy shared machine
# weighs on each the same, and the ratio of each one's median overhead to the first's is printed.
#
#   bash bench/whole_process.sh [runs] [lensfarm binary ...]
#   SCENE=scenes/cornell-classic.json RES=1920x1080 SPP=1 bash bench/whole_process.sh 7 build/client/lensfarm
set -euo pipefail
RUNS=${1:-7}
shift || true
BINS=("$@")
[ ${#BINS[@]} -gt 0 ] || BINS=("${BUILD_DIR:-build}/client/lensfarm")
SCENE=${SCENE:-scenes/cornell-classic.json}
RES=${RES:-1920x1080}
SPP=${SPP:-1}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }

for ((r = 1; r <= RUNS; ++r)); do
  for b in "${!BINS[@]}"; do
    log="$out/run-$b-$r"
    t0=$(now)
    LENSFARM_TIMINGS=1 "${BINS[$b]}" render "$SCENE" --resolution "$RES" --spp "$SPP" -q \
      -o "$out/out-$b.exr" -o "$out/out-$b.png" >"$log.out" 2>"$log.err"
    t1=$(now)
    # One "phase milliseconds" line per phase, in the order they happen.
    awk -v t0="$t0" -v t1="$t1" '
      /^timing / { end = $NF; sub(/\)$/, "", end);
                   if ($2 == "main") printf "start %.3f\n", (end - t0) * 1000; else printf "%s %s\n", $2, $3;
                   if ($6 == "faults") printf "faults_%s %s\n", $2, $5;
                   last = end }
      END { printf "exit %.3f\n", (t1 - last) * 1000; printf "whole %.3f\n", (t1 - t0) * 1000 }' \
      "$log.err" >"$log.phases"
    awk '/^time: / { printf "render_printed %.3f\n", $2 * 1000 }' "$log.out" >>"$log.phases"
  done
done

for b in "${!BINS[@]}"; do
  echo "== ${BINS[$b]}: $SCENE at $RES, $SPP spp, $RUNS runs (ms): median, max"
  phases=$(awk '{print $1}' "$out/run-$b-1.phases")
  for p in $phases; do
    m=$(cat "$out"/run-"$b"-*.phases | awk -v p="$p" '$1 == p {print $2}' | median)
    x=$(cat "$out"/run-"$b"-*.phases | awk -v p="$p" '$1 == p {print $2}' | sort -g | tail -1)
    printf "  %-16s %9.1f %9.1f\n" "$p" "$m" "$x"
    [ "$p" = whole ] && whole[$b]=$m
    [ "$p" = render_printed ] && render[$b]=$m
  done
  # The overhead of each run (whole - printed render time), then its median.
  over=$(for f in "$out"/run-"$b"-*.phases; do
    awk '$1 == "whole" {w = $2} $1 == "render_printed" {r = $2} END {print w - r}' "$f"; done | median)
  overhead[$b]=$over
  printf "  %-16s %9.1f             (median of each run's whole - render)\n" "overhead" "$over"
  # The goal (docs/performance.md): at most 250 ms around the render.
  awk -v o="$over" 'BEGIN {printf "  goal: overhead <= 250 ms: %s\n", (o <= 250 ? "met" : "MISSED")}'
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
if [ ${#BINS[@]} -gt 1 ]; then
  for b in "${!BINS[@]}"; do
    awk -v o="${overhead[$b]}" -v o0="${overhead[0]}" -v w="${whole[$b]}" -v w0="${whole[0]}" -v n="${BINS[$b]}" \
      'BEGIN {printf "%s: overhead %.3f x, whole process %.3f x the first\n", n, o / o0, w / w0}'
  done
fi
