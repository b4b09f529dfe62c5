#pragma once
// What varies across a surface at a hit: the shading normal (interpolated vertex normals, then
// the material's normal map) and the texture coordinates with their filter footprint. Only hits
// on a material that RenderScene::shaded() marks are shaded this way; everywhere else the
// geometric normal is the shading normal and nothing is looked up (a scene without vertex normals
// or textures pays nothing).
//
// The rule that keeps shading normals from leaking light (docs/scene-format.md, "Shading normals
// and textures"):
//  1. The shading normal is turned to wo's side of the surface like the geometric one. If it
//     then points into the surface (dot with the geometric normal <= 0), or wo lies below it (a
//     silhouette seen past an interpolated normal), the geometric normal is used at that point.
//  2. A direction wi is scattered only if it lies on the same side of the geometric and of the
//     shading normal (dot(wi, ng) dot(wi, ns) > 0); otherwise its contribution is zero, for light
//     samples and sampled directions alike. Reflection therefore never reaches below the
//     geometric surface, and transmission never stays above it (Veach 1997, §5.3).
// Normal maps follow glTF (glTF 2.0 §3.9.3): RGB = (n + 1) / 2 in the tangent frame (T, B, N),
// T along +u; B = w cross(N, T) from the mesh's tangents, or, without them, the direction of
// decreasing v of the triangle's texture coordinates (the map's green points up in the image),
// made orthonormal to N.
//
// Texture footprint: a camera ray's pixel covers about pixelAngle * distance at a point; pbrt-v4
// approximates the footprint of every hit this way, from its distance to the camera
// (Camera::Approximate_dp_dxy, pbrt-v4 §10.1.2). It is turned into texture space by the
// triangle's ratio of texture area to world area.
#include "common/math/vec.h"
#include "common/render/render_scene.h"

namespace lensfarm {

struct ShadingPoint {
  Vec3 n;           // the shading normal, on wo's side
  Vec2 uv[2];       // texture coordinates (0 where the mesh has none)
  float footprint;  // width of a pixel's footprint in texture space (texture/texture.h)
};

// The shading point of `hit`, seen from wo; nSide is the geometric normal on wo's side and
// `front` whether that is the front face.
ShadingPoint shadingPoint(const RenderScene& rs, const SurfaceHit& hit, const Vec3& wo, const Vec3& nSide, bool front);

// Rule 2 above.
inline bool scattersTo(const Vec3& wi, const Vec3& nGeometric, const Vec3& nShading) {
  return glm::dot(wi, nGeometric) * glm::dot(wi, nShading) > 0.0f;
}

}  // namespace lensfarm
