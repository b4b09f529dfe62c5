#!/usr/bin/env bash
# Two settings of one render field compared by their time to an equal error, same run (e.g. light
# tracing on and off, equiangular sampling on and off): RUNS pairs of renders per setting, run
# alternately (A A B B A A ...) so that a noisy shared machine weighs on both the same.
#
# No converged reference is needed: two independent renders (seeds 2r, 2r+1) of an unbiased
# estimator differ by noise alone, so the relMSE and display RMSE between a pair (lensfarm compare)
# measure each setting's noise at these samples (twice one render's MSE). With the median render
# time t, the time to an equal error is proportional to MSE x t; the script prints that ratio (B
# over A: above 1, A reaches the error sooner). Bias is not seen here: the per-pixel z-tests of
# the estimators' tests check it (docs/numerics.md).
#
#   SCENE=scenes/glass-metal-sky.json FIELD=light_tracing A=auto B=off bash bench/noise_ab.sh [runs]
# RES (WxH, default 128x128), SPP (default 256); PATCH: Python run on the scene's JSON `j` before
# the field is set (a variant of the scene, e.g. bench/media_sampling.sh's fog bank alone).
set -euo pipefail
RUNS=${1:-2}
LENSFARM=${LENSFARM:-${BUILD_DIR:-build}/client/lensfarm}
: "${SCENE:?SCENE=path/to/scene.json}" "${FIELD:?FIELD=a render field}" "${A:?A=value}" "${B:?B=value}"
RES=${RES:-128x128}
SPP=${SPP:-256}
PATCH=${PATCH:-}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The variants sit beside the scene's own files (meshes, textures), linked into the temp dir.
for f in "$(dirname "$SCENE")"/*; do ln -s "$(realpath "$f")" "$out/"; done

for side in A B; do
  python3 - "$SCENE" "$out/variant-$side.json" "$FIELD" "${!side}" "$PATCH" <<'EOF'
import json, sys
scene, target, field, value, patch = sys.argv[1:]
j = json.load(open(scene))
exec(patch)
try:
    value = json.loads(value)
except ValueError:
    pass
j.setdefault("render", {})[field] = value
json.dump(j, open(target, "w"))
EOF
done

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
for ((r = 1; r <= RUNS; ++r)); do
  for side in A B; do
    for half in a b; do
      [ "$half" = b ] && seed=$((2 * r + 1)) || seed=$((2 * r))
      t0=$(now)
      "$LENSFARM" render "$out/variant-$side.json" --resolution "$RES" --spp "$SPP" --seed "$seed" -q \
        --allow-path "$(realpath "$(dirname "$SCENE")")" -o "$out/$side-$r-$half.exr" >/dev/null 2>"$out/render.log" ||
        { cat "$out/render.log" >&2; exit 1; }
      t1=$(now)
      echo "$t1 - $t0" | bc >>"$out/$side.seconds"
    done
    "$LENSFARM" compare "$out/$side-$r-a.exr" "$out/$side-$r-b.exr" --tolerance 1e9 >"$out/$side-$r.compare"
    awk '/^relMSE:/ {print $2}' "$out/$side-$r.compare" >>"$out/$side.relmse"
    awk '/^display RMSE:/ {print $3 * $3}' "$out/$side-$r.compare" >>"$out/$side.display"
  done
done

echo "$SCENE at $RES, $SPP spp, medians of $RUNS pair(s) per setting; A: $FIELD=$A, B: $FIELD=$B"
printf "%-3s %10s %12s %16s\n" "" seconds relMSE "display MSE"
declare -A T M D
for side in A B; do
  T[$side]=$(median <"$out/$side.seconds")
  M[$side]=$(median <"$out/$side.relmse")
  D[$side]=$(median <"$out/$side.display")
  printf "%-3s %10.3f %12.6f %16.8f\n" "$side" "${T[$side]}" "${M[$side]}" "${D[$side]}"
done
awk -v ta="${T[A]}" -v tb="${T[B]}" -v ma="${M[A]}" -v mb="${M[B]}" -v da="${D[A]}" -v db="${D[B]}" 'BEGIN {
    printf "time per sample: A / B = %.2f\n", ta / tb;
    printf "time to equal relMSE: B / A = %.2f\n", (mb * tb) / (ma * ta);
    printf "time to equal display error: B / A = %.2f\n", (db * tb) / (da * ta) }'
