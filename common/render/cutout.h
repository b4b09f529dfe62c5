#pragma once
// Cut-outs (glTF alphaMode MASK; BLEND is rendered as MASK at 0.5): a hit on a triangle whose
// material's alpha, read at the finest texture level, is below its cutoff is no hit at all, for
// every ray alike. The ray caster applies it in Embree's filter functions and in the precise
// triangles' own test (render/precise_triangles.h).
#include "common/scene/scene.h"

namespace lensfarm {

// Whether a mesh has a triangle with a cut-out material (only such meshes are tested).
bool meshCutsOut(const Scene& scene, const TriangleMesh& mesh);

// Whether triangle `triangle` of `mesh` lets a ray through at barycentrics (b1, b2).
// Deterministic: a function of the hit alone.
bool cutsAway(const Scene& scene, const TriangleMesh& mesh, unsigned triangle, float b1, float b2);

}  // namespace lensfarm
