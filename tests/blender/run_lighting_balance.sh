#!/usr/bin/env bash
# ctest's Blender.LampsAndEmittersKeepCyclesBalance: runs lighting_balance.py (a scene per light kind,
# built in Blender, rendered by Cycles, exported by Blender's glTF add-on and rendered by lensfarm)
# in a temporary folder that is removed afterwards.
#
#   tests/blender/run_lighting_balance.sh PATH/TO/lensfarm [extra lighting_balance.py arguments]
#
# Exit 0: pass; 1: lensfarm and Cycles disagree; 77: skipped (no `blender`, or its Python has no
# numpy: scripts/setup.sh test installs both); anything else: an error. Set LENSFARM_BLENDER_KEEP=1
# to keep the folder (scenes, .blend, .glb, both EXRs, summary.json) for a look.
set -uo pipefail

if [ $# -lt 1 ]; then
  echo "usage: $0 PATH/TO/lensfarm [lighting_balance.py arguments]" >&2
  exit 2
fi
lensfarm=$1
shift

blender=${BLENDER:-blender}
if ! command -v "$blender" >/dev/null 2>&1; then
  echo "SKIP: no '$blender' on PATH (scripts/setup.sh test installs Debian's blender)"
  exit 77
fi
# Blender runs on the system Python (Debian); its glTF exporter needs numpy. Asking Blender's own
# interpreter costs a second but is the only check that cannot disagree with it.
if ! "$blender" -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1; then
  echo "SKIP: Blender's Python cannot import numpy (scripts/setup.sh test installs python3-numpy)"
  exit 77
fi

here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/lensfarm-blender.XXXXXX")"
if [ "${LENSFARM_BLENDER_KEEP:-0}" = 1 ]; then
  echo "keeping $work"
else
  trap 'rm -rf "$work"' EXIT
fi

"$blender" -b --factory-startup --python-exit-code 2 --python "$here/lighting_balance.py" -- \
  --lensfarm "$lensfarm" --out "$work/out" "$@" >"$work/blender.log" 2>&1
rc=$?

if [ $rc -eq 0 ]; then
  grep -E '^(CASE|PASSED|FAILED|SKIP)' "$work/blender.log"
else
  # The log without Blender's chatter: Cycles' progress lines, saved files, the exporter's INFO
  # lines and Debian's "ERROR: Draco mesh compression is not available" (harmless: Draco is not used).
  grep -v -E '^Fra:|^Saved: |^ Time: |^Info: |\| INFO: |Draco mesh compression|^$' "$work/blender.log"
  echo "(LENSFARM_BLENDER_KEEP=1 keeps the scenes, the images and summary.json)"
fi
exit $rc
