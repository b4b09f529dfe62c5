#include "render/shading_point.h"

#include <cmath>

namespace lensfarm {

namespace {
// |a x b| of two 2D vectors (twice a texture-space triangle's area).
float cross2(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }

// The normal map's perturbation of the (front-face) shading normal n at a point of a triangle
// with vertices p and texture coordinates uv (glTF 2.0 §3.9.3; the header has the frame).
Vec3 applyNormalMap(const MaterialTextures& t, const Vec4& texel, const TriangleMesh& mesh, size_t tri,
                    const Vec3 (&p)[3], const Vec2 (&uv)[3], float b1, float b2, const Vec3& n) {
  Vec3 tangent, bitangent;
  if (!mesh.tangents.empty()) {
    const glm::vec4 t4 = mesh.interpolate(mesh.tangents, tri, b1, b2);
    tangent = Vec3(t4);
    bitangent = (mesh.tangents[mesh.indices[3 * tri]].w < 0.0f ? -1.0f : 1.0f) * glm::cross(n, tangent);
  } else {
    // dp/du and dp/dv of the triangle (pbrt-v4 §6.5.3), solved from its edges.
    const Vec3 dp1 = p[1] - p[0], dp2 = p[2] - p[0];
    const Vec2 duv1 = uv[1] - uv[0], duv2 = uv[2] - uv[0];
    const float det = cross2(duv1, duv2);
    if (!(std::abs(det) > 1e-20f)) return n;  // no texture parametrisation: nothing to map
    tangent = (dp1 * duv2.y - dp2 * duv1.y) / det;
    bitangent = -(dp2 * duv1.x - dp1 * duv2.x) / det;  // towards decreasing v: up in the image
  }
  // Gram-Schmidt against n.
  tangent -= n * glm::dot(n, tangent);
  const float tl = glm::length(tangent);
  if (!(tl > 0.0f) || !std::isfinite(tl)) return n;
  tangent /= tl;
  bitangent -= n * glm::dot(n, bitangent) + tangent * glm::dot(tangent, bitangent);
  const float bl = glm::length(bitangent);
  if (!(bl > 0.0f) || !std::isfinite(bl)) return n;
  bitangent /= bl;
  const Vec3 m(t.normalScale * (2.0f * texel.x - 1.0f), t.normalScale * (2.0f * texel.y - 1.0f), 2.0f * texel.z - 1.0f);
  const Vec3 mapped = tangent * m.x + bitangent * m.y + n * m.z;
  const float length = glm::length(mapped);
  return length > 0.0f && std::isfinite(length) ? mapped / length : n;
}
}  // namespace

ShadingPoint shadingPoint(const RenderScene& rs, const SurfaceHit& hit, const Vec3& wo, const Vec3& nSide, bool front) {
  ShadingPoint sp{nSide, {Vec2(0.0f), Vec2(0.0f)}, 0.0f};
  const RayCaster::MeshTriangle where = rs.caster().meshTriangle(hit.triangle);
  const TriangleMesh& mesh = rs.scene().meshes[where.mesh];
  const uint32_t* idx = &mesh.indices[3 * size_t(where.index)];
  const Vec3 p[3] = {mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]]};
  Vec2 uv[3] = {Vec2(0.0f), Vec2(0.0f), Vec2(0.0f)};
  for (int set = 0; set < 2; ++set) {
    if (mesh.uv[set].empty()) continue;
    sp.uv[set] = mesh.interpolate(mesh.uv[set], where.index, hit.b1, hit.b2);
    if (set == 0) uv[0] = mesh.uv[0][idx[0]], uv[1] = mesh.uv[0][idx[1]], uv[2] = mesh.uv[0][idx[2]];
  }

  const Material& material = rs.material(hit.material);
  const MaterialTextures* textures = material.textures();
  if (textures && textures->varies()) {
    // A pixel's width at the hit, in world units, then in texture units of the set the
    // textures mostly use (TEXCOORD_0's density; a transform's scale is applied per lookup).
    const float world = glm::length(hit.p) * rs.pixelAngle();
    const float worldArea = glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    const float uvArea = std::abs(cross2(uv[1] - uv[0], uv[2] - uv[0]));
    const float ratio = worldArea > 0.0f ? std::sqrt(uvArea / worldArea) : 0.0f;
    sp.footprint = std::isfinite(ratio) ? world * ratio : 0.0f;
  }

  // The front face's shading normal, then turned to wo's side (rule 1).
  Vec3 n = front ? nSide : -nSide;
  if (!mesh.normals.empty()) {
    const Vec3 interpolated = mesh.interpolate(mesh.normals, where.index, hit.b1, hit.b2);
    const float length = glm::length(interpolated);
    if (length > 0.0f && std::isfinite(length)) n = interpolated / length;
  }
  if (textures && textures->normal)
    n = applyNormalMap(*textures, textures->normal.sample(sp.uv, sp.footprint), mesh, where.index, p, uv, hit.b1, hit.b2, n);
  if (!front) n = -n;
  if (glm::dot(n, nSide) > 0.0f && glm::dot(n, wo) > 0.0f) sp.n = n;
  return sp;
}

}  // namespace lensfarm
