#!/usr/bin/env bash
# What equiangular sampling in media buys (docs/media.md, "Equiangular sampling"): a scene with
# render.medium_light_sampling "auto" (equiangular + free flight, by MIS) against "distance"
# (free flight alone), at equal samples, RUNS pairs of renders per method, run alternately (A B A B
# ...) so that a noisy shared machine weighs on both the same.
#
# No converged reference is needed: two independent renders of an unbiased estimator differ by
# noise alone, so the relMSE and display RMSE between a pair (lensfarm compare) measure each
# method's noise at these samples (twice one render's MSE). With the median render time t, the
# time to an equal error is proportional to MSE x t; the script prints that ratio (distance over
# auto: above 1, equiangular reaches the error sooner).
#
#   bash bench/media_sampling.sh [runs]
#   SCENE=scenes/cornell-media.json RES=128x128 SPP=256 VARIANT=fog-only bash bench/media_sampling.sh 2
# VARIANT: "scene" (as shipped) or "fog-only" (cornell-media's fog bank alone: the marble block
# Lambertian, the glass of milk a Lambertian ball, as in the study's "fog bank only" row without
# the glass, whose caustics would dominate the noise).
set -euo pipefail
RUNS=${1:-2}
LENSFARM=${LENSFARM:-${BUILD_DIR:-build}/client/lensfarm}
SCENE=${SCENE:-scenes/cornell-media.json}
RES=${RES:-128x128}
SPP=${SPP:-256}
VARIANT=${VARIANT:-scene}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The variants sit beside the scene's own files (meshes, textures), linked into the temp dir.
for f in "$(dirname "$SCENE")"/*; do ln -s "$(realpath "$f")" "$out/"; done

for mode in auto distance; do
  python3 - "$SCENE" "$out/variant-$mode.json" "$mode" "$VARIANT" <<'EOF'
import json, sys
scene, target, mode, variant = sys.argv[1:]
j = json.load(open(scene))
j.setdefault("render", {})["medium_light_sampling"] = mode
if variant == "fog-only":
    j["materials"]["marble"] = {"type": "lambertian", "albedo": [0.82, 0.8, 0.74]}
    j["materials"]["milk-glass"] = {"type": "lambertian", "albedo": 0.8, "exterior_medium": "haze"}
json.dump(j, open(target, "w"))
EOF
done

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
for ((r = 1; r <= RUNS; ++r)); do
  for mode in auto distance; do
    for half in a b; do
      [ "$half" = b ] && seed=$((2 * r + 1)) || seed=$((2 * r))
      t0=$(now)
      "$LENSFARM" render "$out/variant-$mode.json" --resolution "$RES" --spp "$SPP" --seed "$seed" -q \
        --allow-path "$(realpath "$(dirname "$SCENE")")" -o "$out/$mode-$r-$half.exr" >/dev/null 2>"$out/render.log" ||
        { cat "$out/render.log" >&2; exit 1; }
      t1=$(now)
      echo "$t1 - $t0" | bc >>"$out/$mode.seconds"
    done
    "$LENSFARM" compare "$out/$mode-$r-a.exr" "$out/$mode-$r-b.exr" --tolerance 1e9 >"$out/$mode-$r.compare"
    awk '/^relMSE:/ {print $2}' "$out/$mode-$r.compare" >>"$out/$mode.relmse"
    awk '/^display RMSE:/ {print $3 * $3}' "$out/$mode-$r.compare" >>"$out/$mode.display"
  done
done

echo "$SCENE ($VARIANT) at $RES, $SPP spp, medians of $RUNS pair(s) per method"
printf "%-9s %10s %12s %16s\n" method seconds relMSE "display MSE"
declare -A T M D
for mode in auto distance; do
  T[$mode]=$(median <"$out/$mode.seconds")
  M[$mode]=$(median <"$out/$mode.relmse")
  D[$mode]=$(median <"$out/$mode.display")
  printf "%-9s %10.3f %12.6f %16.8f\n" "$mode" "${T[$mode]}" "${M[$mode]}" "${D[$mode]}"
done
awk -v ta="${T[auto]}" -v td="${T[distance]}" -v ma="${M[auto]}" -v md="${M[distance]}" \
  -v da="${D[auto]}" -v dd="${D[distance]}" 'BEGIN {
    printf "time per sample: auto / distance = %.2f\n", ta / td;
    printf "time to equal relMSE: distance / auto = %.2f\n", (md * td) / (ma * ta);
    printf "time to equal display error: distance / auto = %.2f\n", (dd * td) / (da * ta) }'
