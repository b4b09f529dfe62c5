#include "common/render/shading_point.h"

#include <cmath>

namespace lensfarm {

namespace {
Vec3 unitOrZero(const Vec3& v) {
  const float length = glm::length(v);
  return length > 0.0f && std::isfinite(length) ? v / length : Vec3(0.0f);
}

// A direction attribute (normals, or tangents' xyz) at the hit: on an instance, each vertex's is
// placed by `place` and made unit length before they are interpolated, exactly as the scene
// loader does for a mesh it copies, so that an instance shades as its copy would.
template <typename Attribute, typename Place>
Vec3 interpolatedDirection(const RayCaster::HitMesh& at, const std::vector<Attribute>& attribute, float b1, float b2,
                           Place place) {
  const TriangleMesh& mesh = *at.mesh;
  if (!at.instance) return Vec3(mesh.interpolate(attribute, at.index, b1, b2));
  const uint32_t* idx = &mesh.indices[3 * size_t(at.index)];
  return (1.0f - b1 - b2) * unitOrZero(place(Vec3(attribute[idx[0]]))) +
         b1 * unitOrZero(place(Vec3(attribute[idx[1]]))) + b2 * unitOrZero(place(Vec3(attribute[idx[2]])));
}

// |a x b| of two 2D vectors (twice a texture-space triangle's area).
float cross2(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }

// The normal map's perturbation of the (front-face) shading normal n at a point of a triangle
// with vertices p and texture coordinates uv (glTF 2.0 §3.9.3; the header has the frame).
Vec3 applyNormalMap(const MaterialTextures& t, const Vec4& texel, const RayCaster::HitMesh& at, const Vec3 (&p)[3],
                    const Vec2 (&uv)[3], float b1, float b2, const Vec3& n) {
  const TriangleMesh& mesh = *at.mesh;
  Vec3 tangent, bitangent;
  if (!mesh.tangents.empty()) {
    tangent = interpolatedDirection(at, mesh.tangents, b1, b2, [&](const Vec3& v) { return at.instance->vector(v); });
    const bool flipped =
        (mesh.tangents[mesh.indices[3 * size_t(at.index)]].w < 0.0f) != (at.instance && at.instance->mirrors);
    bitangent = (flipped ? -1.0f : 1.0f) * glm::cross(n, tangent);
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
  const RayCaster::HitMesh where = rs.caster().hitMesh(hit);
  const TriangleMesh& mesh = *where.mesh;
  const uint32_t* idx = &mesh.indices[3 * size_t(where.index)];
  Vec3 p[3] = {mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]]};
  if (where.instance)
    for (Vec3& v : p) v = where.instance->point(v);
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
    const Vec3 interpolated = interpolatedDirection(where, mesh.normals, hit.b1, hit.b2,
                                                    [&](const Vec3& v) { return where.instance->normalMatrix * v; });
    const float length = glm::length(interpolated);
    if (length > 0.0f && std::isfinite(length)) n = interpolated / length;
  }
  if (textures && textures->normal)
    n = applyNormalMap(*textures, textures->normal.sample(sp.uv, sp.footprint), where, p, uv, hit.b1, hit.b2, n);
  if (!front) n = -n;
  if (glm::dot(n, nSide) > 0.0f && glm::dot(n, wo) > 0.0f) sp.n = n;
  return sp;
}

}  // namespace lensfarm
