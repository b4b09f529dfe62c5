#!/usr/bin/env bash
# What equiangular sampling in media buys (docs/media.md, "Equiangular sampling"): a scene with
# render.medium_light_sampling "auto" (A: equiangular + free flight, by MIS) against "distance"
# (B: free flight alone), at equal samples, by bench/noise_ab.sh (time to an equal error from
# pairs of independent renders; above 1, equiangular reaches it sooner).
#
#   bash bench/media_sampling.sh [runs]
#   SCENE=scenes/cornell-media.json RES=128x128 SPP=256 VARIANT=fog-only bash bench/media_sampling.sh 2
# VARIANT: "scene" (as shipped) or "fog-only" (cornell-media's fog bank alone: the marble block
# Lambertian, the glass of milk a Lambertian ball, as in the study's "fog bank only" row without
# the glass, whose caustics would dominate the noise).
set -euo pipefail
PATCH=""
if [ "${VARIANT:-scene}" = fog-only ]; then
  PATCH='j["materials"]["marble"] = {"type": "lambertian", "albedo": [0.82, 0.8, 0.74]}
j["materials"]["milk-glass"] = {"type": "lambertian", "albedo": 0.8, "exterior_medium": "haze"}'
fi
SCENE=${SCENE:-scenes/cornell-media.json} FIELD=medium_light_sampling A=auto B=distance PATCH="$PATCH" \
  exec bash "$(dirname "$0")/noise_ab.sh" "$@"
