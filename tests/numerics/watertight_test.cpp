// Watertightness and self-intersection: rays aimed at the shared edges and vertices of closed
// meshes never slip through, near the origin or far from it; rays spawned from a surface never
// hit it again, at any scale from 1e-8 to 1e8.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "math/ray_offset.h"
#include "render/render_scene.h"
#include "scene/scene_loader.h"
#include "test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A UV sphere of radius 1 as an indexed OBJ: shared vertices, so every edge is shared exactly.
std::string sphereObj(int rings, int segments) {
  std::ostringstream obj;
  obj << "v 0 1 0\n";
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double theta = M_PI * r / rings, phi = 2 * M_PI * s / segments;
      obj << "v " << std::sin(theta) * std::cos(phi) << " " << std::cos(theta) << " " << std::sin(theta) * std::sin(phi) << "\n";
    }
  obj << "v 0 -1 0\n";
  const auto idx = [&](int r, int s) { return 2 + (r - 1) * segments + (s % segments); };  // 1-based
  const int south = 2 + (rings - 1) * segments;
  for (int s = 0; s < segments; ++s) obj << "f 1 " << idx(1, s + 1) << " " << idx(1, s) << "\n";
  for (int r = 1; r < rings - 1; ++r)
    for (int s = 0; s < segments; ++s)
      obj << "f " << idx(r, s) << " " << idx(r, s + 1) << " " << idx(r + 1, s + 1) << " " << idx(r + 1, s) << "\n";
  for (int s = 0; s < segments; ++s) obj << "f " << south << " " << idx(rings - 1, s) << " " << idx(rings - 1, s + 1) << "\n";
  return obj.str();
}

// Casts 10^7 rays from `origin` at the vertices, edges and interiors of every triangle and
// counts those that hit nothing.
uint64_t escapes(const RenderScene& rs, Vec3 origin) {
  const auto& tris = rs.caster().triangles();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  uint64_t missed = 0;
  constexpr int kRays = 10'000'000;
  for (int k = 0; k < kRays; ++k) {
    const auto& t = tris[size_t(k) % tris.size()];
    const int mode = int((size_t(k) / tris.size()) % 4);
    Vec3 target;
    const float a = u(rng);
    if (mode == 0) target = (k % 3 == 0) ? t.v0 : (k % 3 == 1 ? t.v1 : t.v2);  // exactly a vertex
    else if (mode == 1) target = t.v0 * (1 - a) + t.v1 * a;                     // on an edge
    else if (mode == 2) target = t.v2 * (1 - a) + t.v0 * a;
    else target = t.v1 * (1 - a) + t.v2 * a;
    if (!rs.caster().intersect(origin, glm::normalize(target - origin), RayKind::kScattered)) ++missed;
  }
  return missed;
}

class Watertight : public ::testing::TestWithParam<double> {};

TEST_P(Watertight, NoRayEscapesTheClosedCornellBox) {
  const double far = GetParam();
  const Vec3 offset = Vec3(1.5e5f, 1.2e3f, -2.2e5f) * float(far);
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-classic.json");
  scene["shapes"][0]["transform"]["translate"] = {1 + offset.x, 1 + offset.y, -1 + offset.z};
  // The DH2323 box is open at the front: close it.
  scene["shapes"].push_back({{"type", "quad"}, {"corner", {-1 + offset.x, -1 + offset.y, -1 + offset.z}},
                             {"edge1", {2, 0, 0}}, {"edge2", {0, 2, 0}}, {"material", "white"}});
  scene["lights"] = json::array();
  const Scene s = test::loadSceneJson(dir, scene);
  const RenderScene rs(s);
  EXPECT_EQ(escapes(rs, offset + Vec3(0.1f, -0.2f, 0.05f)), 0u);
}

TEST_P(Watertight, NoRayEscapesAFinelyTessellatedSphere) {
  // Far from the origin floats are 1/64 apart, so the sphere is scaled up until its smallest
  // triangles (at the poles) stay representable.
  const double far = GetParam();
  const double radius = far > 0 ? 100.0 : 1.0;
  const Vec3 centre = Vec3(1.5e5f, 1.2e3f, -2.2e5f) * float(far);
  test::TempDir dir;
  dir.write("sphere.obj", sphereObj(96, 192));  // 36 480 triangles
  json scene = test::minimalSceneJson();
  scene["shapes"] = json::array({{{"type", "obj"}, {"file", "sphere.obj"}, {"material", "white"},
                                  {"transform", {{"scale", radius}, {"translate", {centre.x, centre.y, centre.z}}}}}});
  scene["lights"] = json::array();
  const Scene s = test::loadSceneJson(dir, scene);
  const RenderScene rs(s);
  if (far == 0) {
    EXPECT_EQ(rs.caster().triangles().size(), 36480u);
  }
  EXPECT_EQ(escapes(rs, centre + Vec3(0.05f, -0.1f, 0.0f) * float(radius)), 0u);
}

INSTANTIATE_TEST_SUITE_P(NearAndFar, Watertight, ::testing::Values(0.0, 1.0),
                         [](const auto& p) { return p.param == 0.0 ? "AtTheOrigin" : "FarFromTheOrigin"; });

TEST(SelfIntersection, SpawnedRaysNeverHitTheirOwnSurfaceAtAnyScale) {
  // One triangle per scale, randomly oriented, with coordinates from 1e-8 to 1e8. From points
  // on it, rays leave into both hemispheres (down to grazing) through offsetRayOrigin: with
  // nothing else in the scene, any hit is a self-hit.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), v(0.0f, 1.0f);
  for (double scale : {1e-8, 1e-4, 1.0, 1e4, 1e8}) {
    Scene scene;
    scene.materials.push_back(Material{});
    TriangleMesh mesh;
    for (int k = 0; k < 3; ++k) mesh.positions.push_back(Vec3(u(rng), u(rng), u(rng)) * float(scale));
    mesh.positions.push_back(mesh.positions[0] + Vec3(float(scale) * 3));  // offset the whole triangle
    mesh.positions[0] = mesh.positions[3];
    mesh.indices = {0, 1, 2};
    mesh.materialIds = {0};
    scene.meshes.push_back(mesh);
    scene.render.width = scene.render.height = 1;
    scene.cameraParams.focalLength = 1;
    scene.cameraParams.focusDistance = 2;
    scene.cameraParams.sensorWidth = 1;
    const RenderScene rs(scene);
    const auto& t = rs.caster().triangles()[0];
    const Frame frame = Frame::fromNormal(t.n);
    uint64_t selfHits = 0;
    for (int k = 0; k < 200000; ++k) {
      float b0 = v(rng), b1 = v(rng);
      if (b0 + b1 > 1) b0 = 1 - b0, b1 = 1 - b1;
      const Vec3 p = b0 * t.v0 + b1 * t.v1 + (1 - b0 - b1) * t.v2;
      Vec3 local(u(rng), u(rng), std::abs(u(rng)) * 1e-3f + (k % 4 == 0 ? 0.0f : v(rng)));  // some near-grazing
      if (k % 2) local.z = -local.z;
      const Vec3 w = glm::normalize(frame.toWorld(local));
      const Vec3 o = offsetRayOrigin(p, t.n, positionErrorBound(t.magnitude), w);
      if (rs.caster().intersect(o, w, RayKind::kScattered)) ++selfHits;
    }
    EXPECT_EQ(selfHits, 0u) << "scale " << scale;
  }
}

TEST(SelfIntersection, NextFloatMatchesTheLibrarysNextafter) {
  // The offset's last step rounds away from the surface with bit arithmetic instead of
  // std::nextafter; both must agree everywhere, signed zeros, subnormals and extremes included.
  std::vector<float> values = {0.0f, -0.0f, 1.0f, -1.0f, std::numeric_limits<float>::denorm_min(),
                               -std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min(),
                               std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                               std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
  std::mt19937 rng(7);
  std::uniform_int_distribution<uint32_t> bits;
  for (int k = 0; k < 100000; ++k) {
    const float v = std::bit_cast<float>(bits(rng));
    if (!std::isnan(v)) values.push_back(v);
  }
  const float inf = std::numeric_limits<float>::infinity();
  for (float v : values) {
    const float up = std::nextafter(v, inf), down = std::nextafter(v, -inf);
    EXPECT_EQ(std::bit_cast<uint32_t>(nextFloatUp(v)), std::bit_cast<uint32_t>(up)) << v;
    EXPECT_EQ(std::bit_cast<uint32_t>(nextFloatDown(v)), std::bit_cast<uint32_t>(down)) << v;
  }
}

}  // namespace
}  // namespace lensfarm
