#!/usr/bin/env bash
# Time to the same error, lensfarm against Blender Cycles (Debian's 3.4, CPU) on one scene built in
# Blender and exported to glTF by Blender itself (bench/cycles/cornell_copper.py: a Cornell box of
# principled materials with a copper, white or glass sphere). Each renderer is measured against its
# own converged reference (their images differ slightly: filters, lamp sides), in the same run on
# the same machine:
#
#   BUILD_DIR=build bash bench/cycles_compare.sh [copper|white|glass]
#
# Environment: SIZE (pixels per side, 200), SPP (comma list, "16,64,256"), REF_SPP (4096),
# BOUNCES (lensfarm's B, 3; Cycles' Max Bounces B - 1), THREADS (2).
#
# Seconds: Cycles' bpy.ops.render.render (its scene sync, BVH build and sampling; Blender's start-up
# and the export excluded); lensfarm's whole `lensfarm render` process (start-up, glTF import, BVH,
# sampling, EXR written): the comparison is conservative for lensfarm. Per renderer, the time to
# 5 % relative RMSE is extrapolated from its largest sample count as error ~ 1/sqrt(time); the
# table prints every point so the extrapolation can be checked. Exit 0 with the table; 77 where
# Blender or its numpy is missing (scripts/setup.sh test installs both).
set -euo pipefail
cd "$(dirname "$0")/.."
material=${1:-copper}
BUILD_DIR=${BUILD_DIR:-build}
SIZE=${SIZE:-200}
SPP=${SPP:-16,64,256}
REF_SPP=${REF_SPP:-4096}
BOUNCES=${BOUNCES:-3}
THREADS=${THREADS:-2}
lensfarm=$BUILD_DIR/client/lensfarm
blender=${BLENDER:-blender}
command -v "$blender" >/dev/null 2>&1 || { echo "SKIP: no $blender on PATH"; exit 77; }
[ -x "$lensfarm" ] || { echo "no $lensfarm: build first (make build)" >&2; exit 2; }

work=$(mktemp -d "${TMPDIR:-/tmp}/lensfarm-cycles.XXXXXX")
trap 'rm -rf "$work"' EXIT

echo "# Cycles: $material sphere, ${SIZE}x${SIZE}, B = $BOUNCES, spp $SPP, reference $REF_SPP spp, $THREADS threads"
"$blender" -b --factory-startup --python-exit-code 2 --python bench/cycles/cornell_copper.py -- "$work" \
  --spp "$SPP" --reference-spp "$REF_SPP" --size "$SIZE" --bounces "$BOUNCES" --threads "$THREADS" \
  --material "$material" > "$work/blender.log" 2>&1 || { tail -20 "$work/blender.log"; exit 2; }
cycles_json=$(grep '^RESULT_JSON ' "$work/blender.log" | sed 's/^RESULT_JSON //')

# lensfarm renders the .glb as it is: one process per sample count, timed whole.
render() {  # spp output -> seconds
  local start end
  start=$(date +%s.%N)
  "$lensfarm" render "$work/scene.glb" --resolution "${SIZE}x${SIZE}" --spp "$1" --max-bounces "$BOUNCES" \
    --threads "$THREADS" -o "$2" -q > /dev/null 2>&1
  end=$(date +%s.%N)
  python3 -c "print(round($end - $start, 3))"
}
echo "# lensfarm: rendering"
declare -A lf_seconds
for spp in ${SPP//,/ }; do lf_seconds[$spp]=$(render "$spp" "$work/lensfarm-$spp.exr"); done
lf_ref_seconds=$(render "$REF_SPP" "$work/lensfarm-reference.exr")

error() {  # image reference -> relative RMSE
  "$lensfarm" compare "$1" "$2" --tolerance 1e9 | awk '/^relative RMSE:/ {print $3}'
}
{
  echo "renderer spp seconds relative_rmse"
  for spp in ${SPP//,/ }; do
    echo "cycles $spp $(python3 -c "import json; print(json.loads('''$cycles_json''')['seconds']['$spp'])") $(error "$work/cycles-$spp.exr" "$work/cycles-reference.exr")"
    echo "lensfarm $spp ${lf_seconds[$spp]} $(error "$work/lensfarm-$spp.exr" "$work/lensfarm-reference.exr")"
  done
} > "$work/points.txt"
python3 - "$work/points.txt" "$cycles_json" "$lf_ref_seconds" <<'EOF'
import json, sys
rows = [l.split() for l in open(sys.argv[1]).read().split("\n")[1:] if l.strip()]
cycles = json.loads(sys.argv[2])
print(f"| renderer | spp | seconds | relative RMSE |\n|---|---|---|---|")
best = {}
for name, spp, seconds, err in rows:
    print(f"| {name} | {spp} | {float(seconds):.2f} | {float(err) * 100:.2f} % |")
    best[name] = (float(seconds), float(err))  # the largest sample count comes last
print(f"(references: Cycles {cycles['reference_spp']} spp in {cycles['reference_seconds']} s, "
      f"lensfarm in {sys.argv[3]} s)")
to5 = {name: s * (e / 0.05) ** 2 for name, (s, e) in best.items()}
for name, t in to5.items():
    print(f"time to 5 % relative RMSE, {name}: {t:.2f} s")
print(f"lensfarm reaches it {to5['cycles'] / to5['lensfarm']:.2f}x sooner than Cycles")
EOF
