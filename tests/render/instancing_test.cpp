// Instancing (scene/scene.h, MeshInstance; render/ray_caster.h): a glTF mesh that several nodes
// use is stored once and traced through Embree instances. Checked against the same model with
// "instancing": false, whose every use is a copy in render space (the path every other mesh
// takes): ray by ray (the same hits, normals and shading normals, in the one-ray and the packet
// form), image by image (statistically), far from the origin; spawned rays never hit their own
// instanced triangle under a transform that stretches and turns it; a mesh used a thousand times
// holds its triangles once (Embree's own memory report, and the job's estimate, are printed).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "common/farm/memory_estimate.h"
#include "common/render/render_scene.h"
#include "common/render/shading_point.h"
#include "common/util/error.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// Where the models sit in world space: far from the origin, as scenes exported in survey or
// planet coordinates do (the scene loader moves the camera to render space's origin).
const DVec3 kFar(1.0e6, -2.0e6, 5.0e5);

// A UV sphere of radius 1 with vertex normals and uv, as glTF arrays.
struct Sphere {
  std::vector<float> positions, normals, uvs;
  std::vector<uint16_t> indices;
  Sphere(int rings, int segments) {
    for (int r = 0; r <= rings; ++r)
      for (int s = 0; s <= segments; ++s) {
        const double theta = M_PI * r / rings, phi = 2 * M_PI * s / segments;
        const float x = float(std::sin(theta) * std::cos(phi)), y = float(std::cos(theta)),
                    z = float(-std::sin(theta) * std::sin(phi));
        positions.insert(positions.end(), {x, y, z});
        normals.insert(normals.end(), {x, y, z});
        uvs.insert(uvs.end(), {float(s) / float(segments), float(r) / float(rings)});
      }
    const auto at = [&](int r, int s) { return uint16_t(r * (segments + 1) + s); };
    for (int r = 0; r < rings; ++r)
      for (int s = 0; s < segments; ++s) {
        // Counter-clockwise seen from outside (+y is r = 0, phi grows towards -z).
        if (r > 0) indices.insert(indices.end(), {at(r, s), at(r + 1, s), at(r, s + 1)});
        if (r < rings - 1) indices.insert(indices.end(), {at(r, s + 1), at(r + 1, s), at(r + 1, s + 1)});
      }
  }
  size_t triangles() const { return indices.size() / 3; }
  int addTo(test::Builder& b, int material) const {
    if (!b.doc.contains("meshes")) b.doc["meshes"] = json::array();
    return b.add("meshes", {{"primitives",
                             {{{"attributes",
                                {{"POSITION", b.floats(positions, "VEC3")},
                                 {"NORMAL", b.floats(normals, "VEC3")},
                                 {"TEXCOORD_0", b.floats(uvs, "VEC2")}}},
                               {"indices", b.indices(indices)},
                               {"material", material}}}}});
  }
};

// A matte material (exactly Lambertian), a glass one and an emitting one.
void addMaterials(test::Builder& b) {
  b.doc["materials"] = json::array();
  b.add("materials", {{"name", "matte"},
                      {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.5, 0.3, 1.0}}, {"metallicFactor", 0.0}}},
                      {"extensions", {{"KHR_materials_specular", {{"specularFactor", 0.0}}}}}});
  b.add("materials", {{"name", "glass"},
                      {"pbrMetallicRoughness", {{"metallicFactor", 0.0}, {"roughnessFactor", 0.0}}},
                      {"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}}}}});
  b.add("materials", {{"name", "glow"}, {"emissiveFactor", {1.0, 1.0, 1.0}}});
  b.doc["extensionsUsed"] = {"KHR_materials_specular", "KHR_materials_transmission"};
}

json node(int mesh, const json& fields) {
  json n = fields;
  n["mesh"] = mesh;
  return n;
}

// glTF column-major 4x4 of scale, then rotation about `axis` by `degrees`, then translation.
json matrixOf(const DVec3& scale, const DVec3& axis, double degrees, const DVec3& translation) {
  glm::dmat4 m(1.0);
  m = glm::translate(m, translation);
  m = glm::rotate(m, glm::radians(degrees), glm::normalize(axis));
  m = glm::scale(m, scale);
  json out = json::array();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out.push_back(m[c][r]);
  return out;
}

// Two spheres (matte and glass) placed by nodes under transforms of every kind: plain moves,
// turns, non-uniform scales and mirrors, in a hierarchy.
test::Builder placedSpheres() {
  test::Builder b;
  addMaterials(b);
  const Sphere sphere(12, 24);
  sphere.addTo(b, 0);
  sphere.addTo(b, 1);
  b.doc["nodes"] = json::array();
  b.add("nodes", {{"children", {1, 2, 3, 4, 5, 6}}, {"rotation", {0.0, 0.1305262, 0.0, 0.9914449}}});
  b.add("nodes", node(0, {{"translation", {-3.0, 0.0, 0.0}}}));
  b.add("nodes", node(0, {{"matrix", matrixOf(DVec3(1.5, 0.5, 1.0), DVec3(1, 2, 3), 40.0, DVec3(0.0, 1.5, -1.0))}}));
  b.add("nodes", node(0, {{"scale", {-1.0, 1.0, 1.0}}, {"translation", {3.0, 0.0, 0.0}}}));
  b.add("nodes", node(1, {{"translation", {0.0, -0.5, 2.0}}, {"scale", {0.8, 0.8, 0.8}}}));
  b.add("nodes", node(1, {{"matrix", matrixOf(DVec3(-0.6, 0.9, 0.6), DVec3(0, 1, 0), 70.0, DVec3(-2.0, -1.0, 3.0))}}));
  b.add("nodes", node(0, {{"scale", {0.5, 2.0, 0.5}}, {"translation", {2.0, -1.5, 3.0}}}));
  b.doc["scenes"] = {{{"nodes", {0}}}};
  return b;
}

// A scene around model file `file` (moved by kFar): a floor, a quad light, a camera 12 units
// away.
json sceneAround(const std::string& file, bool instancing, int resolution = 32) {
  const DVec3 at = kFar;
  return {{"format", "lensfarm-scene/1"},
          {"camera",
           {{"type", "pinhole"},
            {"position", {at.x + 1.0, at.y + 3.0, at.z + 12.0}},
            {"look_at", {at.x, at.y, at.z}},
            {"angle_of_view", 50}}},
          {"render",
           {{"resolution", {resolution, resolution}}, {"samples_per_pixel", 16}, {"max_bounces", 4}, {"seed", 1}}},
          {"materials", {{"floor", {{"type", "lambertian"}, {"albedo", 0.6}}}}},
          {"shapes",
           {{{"type", "gltf"},
             {"file", file},
             {"instancing", instancing},
             {"transform", {{"translate", {at.x, at.y, at.z}}}}},
            {{"type", "quad"},
             {"material", "floor"},
             {"corner", {at.x - 20, at.y - 3, at.z + 20}},
             {"edge1", {40, 0, 0}},
             {"edge2", {0, 0, -40}}}}},
          {"lights",
           {{{"type", "quad"},
             {"corner", {at.x - 3, at.y + 8, at.z - 3}},
             {"edge1", {6, 0, 0}},
             {"edge2", {0, 0, 6}},
             {"radiance", 6}}}}};
}

void write(const test::TempDir& dir, const std::string& name, const std::string& bytes) {
  std::ofstream(dir.path() / name, std::ios::binary) << bytes;
}

// Directions from the camera (render space's origin) over the picture, `n` x `n`.
std::vector<Vec3> cameraDirections(const Scene& scene, int n) {
  const ThinLensCamera camera = scene.camera();
  const Vec3 forward = camera.forward();
  const Vec3 right = glm::normalize(glm::cross(forward, Vec3(0, 1, 0)));
  const Vec3 up = glm::cross(right, forward);
  std::vector<Vec3> out;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float x = (float(i) + 0.5f) / float(n) - 0.5f, y = (float(j) + 0.5f) / float(n) - 0.5f;
      out.push_back(glm::normalize(forward + 0.9f * (x * right + y * up)));
    }
  return out;
}

TEST(Instancing, ASharedMeshIsStoredOnceAndPlacedByEachNode) {
  test::TempDir dir;
  write(dir, "spheres.glb", placedSpheres().glb());
  const Scene instanced = test::loadSceneJson(dir, sceneAround("spheres.glb", true));
  const Scene copied = test::loadSceneJson(dir, sceneAround("spheres.glb", false));
  const size_t sphere = Sphere(12, 24).triangles();
  ASSERT_EQ(instanced.prototypes.size(), 2u);
  EXPECT_EQ(instanced.instances.size(), 6u);
  EXPECT_EQ(instanced.prototypes[0].triangleCount() + instanced.prototypes[1].triangleCount(), 2 * sphere);
  EXPECT_EQ(storedTriangles(instanced), 2 * sphere + 4);  // the two spheres once, the floor, the light
  EXPECT_TRUE(copied.prototypes.empty() && copied.instances.empty());
  EXPECT_EQ(storedTriangles(copied), 6 * sphere + 4);
  EXPECT_EQ(instanced.instances[3].mirrors, false);
  EXPECT_EQ(instanced.instances[2].mirrors, true);  // scale -1 in x
  EXPECT_EQ(instanced.instances[4].mirrors, true);  // scale -0.6 in x
}

TEST(Instancing, InstancesGiveTheHitsOfCopiesRayByRay) {
  test::TempDir dir;
  write(dir, "spheres.glb", placedSpheres().glb());
  const Scene a = test::loadSceneJson(dir, sceneAround("spheres.glb", true));
  const Scene b = test::loadSceneJson(dir, sceneAround("spheres.glb", false));
  const RenderScene instanced(a), copied(b);
  const std::vector<Vec3> directions = cameraDirections(a, 160);
  size_t onInstances = 0, disagree = 0, mirroredHits = 0;
  for (const Vec3& d : directions) {
    const auto x = instanced.caster().intersect(Vec3(0.0f), d, RayKind::kCamera);
    const auto y = copied.caster().intersect(Vec3(0.0f), d, RayKind::kCamera);
    if (x.has_value() != y.has_value()) {  // only where a ray grazes a silhouette
      ++disagree;
      continue;
    }
    if (!x) continue;
    if (std::abs(x->t - y->t) > 1e-4f * y->t || a.materials[x->material].name != b.materials[y->material].name) {
      ++disagree;  // a ray through an edge may meet the neighbouring triangle of another surface
      continue;
    }
    if (x->instance == kNoInstance) continue;  // the floor
    ++onInstances;
    mirroredHits += a.instances[x->instance].mirrors ? 1 : 0;
    EXPECT_NEAR(glm::length(x->p - y->p), 0.0f, 1e-4f * y->t);
    // The geometric normal faces the same way (a mirrored instance keeps the model's front).
    EXPECT_GT(glm::dot(x->n, y->n), 0.9999f);
    // So does the shading normal, from the vertex normals (turned by the instance's cofactor).
    const Vec3 wo = -d;
    const bool front = glm::dot(x->n, wo) >= 0.0f;
    const ShadingPoint sx = shadingPoint(instanced, *x, wo, front ? x->n : -x->n, front);
    const ShadingPoint sy = shadingPoint(copied, *y, wo, front ? y->n : -y->n, front);
    EXPECT_GT(glm::dot(sx.n, sy.n), 0.9999f);
    EXPECT_NEAR(sx.uv[0].x, sy.uv[0].x, 1e-4f);
    EXPECT_NEAR(sx.uv[0].y, sy.uv[0].y, 1e-4f);
  }
  EXPECT_GT(onInstances, directions.size() / 8);
  EXPECT_GT(mirroredHits, directions.size() / 50);
  EXPECT_LE(disagree, directions.size() / 200);

  // The packet form decodes an instance's hit exactly as the one-ray form does.
  for (size_t first = 0; first + kPacketWidth <= directions.size(); first += 37 * kPacketWidth) {
    RayPacket rays;
    rays.clear();
    for (int k = 0; k < kPacketWidth; ++k) rays.set(k, Vec3(0.0f), directions[first + size_t(k)]);
    RayCaster::PacketHits hits;
    instanced.caster().intersect(rays, RayKind::kCamera, hits);
    for (int k = 0; k < kPacketWidth; ++k) {
      const auto single = instanced.caster().intersect(Vec3(0.0f), rays.direction(k), RayKind::kCamera);
      ASSERT_EQ(hits.found[k] != 0, single.has_value());
      if (!single) continue;
      const SurfaceHit lane = hits.hit(k);
      EXPECT_EQ(std::memcmp(&lane, &*single, sizeof(SurfaceHit)), 0) << "ray " << first + size_t(k);
    }
  }
}

TEST(Instancing, InstancesRenderLikeCopies) {
  test::TempDir dir;
  write(dir, "spheres.glb", placedSpheres().glb());
  test::expectSameImage(test::renderStatistics(test::loadSceneJson(dir, sceneAround("spheres.glb", true, 24)), 16),
                        test::renderStatistics(test::loadSceneJson(dir, sceneAround("spheres.glb", false, 24)), 16));
}

// Under a transform that turns and stretches (condition number 25) a sphere placed 10^4 units
// from the camera, a ray spawned from an instanced hit (math/ray_offset.h) never meets the
// triangle it leaves: Embree intersects it in object space, after rounding the origin there.
TEST(Instancing, SpawnedRaysNeverHitTheirOwnInstancedTriangle) {
  test::TempDir dir;
  test::Builder b;
  addMaterials(b);
  Sphere(16, 32).addTo(b, 0);
  const json m = matrixOf(DVec3(5.0, 0.2, 1.0), DVec3(1, 2, 3), 37.0, DVec3(0.0));
  b.doc["nodes"] = json::array({node(0, {{"matrix", m}}), node(0, {{"translation", {0, 0, 40}}})});
  b.doc["scenes"] = {{{"nodes", {0, 1}}}};
  write(dir, "far.glb", b.glb());
  json scene = sceneAround("far.glb", true, 8);
  scene["camera"]["position"] = {kFar.x - 1.0e4, kFar.y, kFar.z};
  scene["shapes"][0]["transform"] = {{"translate", {kFar.x, kFar.y, kFar.z}}};
  const Scene s = test::loadSceneJson(dir, scene);
  ASSERT_EQ(s.instances.size(), 2u);
  const RenderScene rs(s);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const Vec3 centre(1.0e4f, 0.0f, 0.0f), near = centre + Vec3(0.0f, 0.0f, -20.0f);
  size_t spawned = 0, selfHits = 0;
  std::string first;
  for (int k = 0; k < 150000; ++k) {
    const Vec3 target = centre + Vec3(5.0f * u(rng), 5.0f * u(rng), 5.0f * u(rng));
    const auto hit = rs.caster().intersect(near, glm::normalize(target - near), RayKind::kScattered);
    if (!hit || hit->instance != 0) continue;
    for (int j = 0; j < 4; ++j) {
      Vec3 w(u(rng), u(rng), u(rng));
      if (!(glm::length(w) > 0.1f)) continue;
      w = glm::normalize(w);
      const Vec3 from = spawnOrigin(hit->p, hit->plane(), w);
      const auto next = rs.caster().intersect(from, w, RayKind::kScattered);
      ++spawned;
      if (next && next->instance == hit->instance && next->triangle == hit->triangle) {
        if (selfHits++ == 0)
          first = "a self-hit at t " + std::to_string(next->t) + ", margin " + std::to_string(hit->margin);
      }
      const float along = 1e-3f;  // a shadow ray to just beyond the spawn point must not be blocked
      if (rs.caster().occluded(from, w, along) && !(next && next->t < along)) {
        if (selfHits++ == 0) first = "a shadow ray blocked, margin " + std::to_string(hit->margin);
      }
    }
  }
  EXPECT_GT(spawned, 20000u);
  EXPECT_EQ(selfHits, 0u) << "of " << spawned << "; the first: " << first;
}

// One mesh, placed once and a thousand times: the thousand hold its triangles once. Embree's
// memory grows by the instances alone (within the estimate's kSceneBytesPerInstance each), and a
// thousand copies take about a thousand times the one. The figures are printed.
TEST(Instancing, AThousandInstancesHoldTheMeshOnce) {
  test::TempDir dir;
  const Sphere sphere(16, 32);
  const auto model = [&](int uses) {
    test::Builder b;
    addMaterials(b);
    sphere.addTo(b, 0);
    b.doc["nodes"] = json::array();
    json roots = json::array();
    for (int k = 0; k < uses; ++k) {
      const double x = 3.0 * (k % 10) - 13.5, y = 3.0 * ((k / 10) % 10) - 13.5, z = -3.0 * (k / 100);
      roots.push_back(b.add("nodes", node(0, {{"translation", {x, y, z}}, {"scale", {1.2, 1.0, 0.8}}})));
    }
    b.doc["scenes"] = {{{"nodes", roots}}};
    return b.glb();
  };
  write(dir, "one.glb", model(1));
  write(dir, "thousand.glb", model(1000));
  const auto sceneOf = [&](const std::string& file, bool instancing) {
    json s = sceneAround(file, instancing, 24);
    s["camera"]["position"] = {kFar.x, kFar.y, kFar.z + 60.0};
    return s;
  };
  struct Figures {
    uint64_t triangles, embree, estimate;
  };
  const auto measure = [&](const Scene& s) {
    const RenderScene rs(s);
    const uint64_t estimate = workerJobMemory(s.render, storedTriangles(s), sceneDataBytes(s)).total();
    return Figures{storedTriangles(s), uint64_t(rs.caster().embreeBytes()), estimate};
  };
  const Scene oneScene = test::loadSceneJson(dir, sceneOf("one.glb", true));
  const Scene thousandScene = test::loadSceneJson(dir, sceneOf("thousand.glb", true));
  const Scene copiesScene = test::loadSceneJson(dir, sceneOf("thousand.glb", false));
  ASSERT_EQ(oneScene.instances.size(), 0u);  // one use: an ordinary mesh
  ASSERT_EQ(thousandScene.instances.size(), 1000u);
  const Figures one = measure(oneScene), thousand = measure(thousandScene), copies = measure(copiesScene);
  std::cout << "sphere of " << sphere.triangles() << " triangles: placed once: " << one.triangles
            << " triangles, Embree " << one.embree << " B, job estimate " << one.estimate
            << " B; 1000 instances: " << thousand.triangles << " triangles, Embree " << thousand.embree
            << " B, estimate " << thousand.estimate << " B; 1000 copies: " << copies.triangles << " triangles, Embree "
            << copies.embree << " B, estimate " << copies.estimate << " B\n";
  RecordProperty("embree_bytes_one", std::to_string(one.embree));
  RecordProperty("embree_bytes_1000_instances", std::to_string(thousand.embree));
  RecordProperty("embree_bytes_1000_copies", std::to_string(copies.embree));
  EXPECT_EQ(thousand.triangles, one.triangles);
  EXPECT_EQ(copies.triangles, 1000 * (one.triangles - 4) + 4);
  EXPECT_LE(thousand.embree, one.embree + 1000 * kSceneBytesPerInstance);
  EXPECT_GT(copies.embree, 20 * thousand.embree);
  EXPECT_LT(thousand.estimate, copies.estimate / 20);
  EXPECT_GE(thousand.estimate, one.estimate + 1000 * kSceneBytesPerInstance);

  // And the thousand render as the thousand copies do.
  test::expectSameImage(test::renderStatistics(test::loadSceneJson(dir, sceneOf("thousand.glb", true)), 16),
                        test::renderStatistics(test::loadSceneJson(dir, sceneOf("thousand.glb", false)), 16));
}

// A scene of instances alone (no other mesh, lit by the sky), as `lensfarm render model.glb`
// gives for a model whose meshes are all shared.
TEST(Instancing, ASceneOfInstancesAloneRendersLikeItsCopies) {
  test::TempDir dir;
  write(dir, "spheres.glb", placedSpheres().glb());
  const auto sceneOf = [&](bool instancing) {
    json s = sceneAround("spheres.glb", instancing, 24);
    s["shapes"] = json::array({s["shapes"][0]});
    s.erase("lights");
    s["environment"] = {{"radiance", {1.0, 0.9, 0.8}}};
    return test::loadSceneJson(dir, s);
  };
  const Scene alone = sceneOf(true);
  ASSERT_TRUE(alone.meshes.empty());
  ASSERT_EQ(alone.instances.size(), 6u);
  test::expectSameImage(test::renderStatistics(alone, 16), test::renderStatistics(sceneOf(false), 16));
}

TEST(Instancing, AnEmittingMeshIsCopiedForEachUseAndSaysSo) {
  test::TempDir dir;
  test::Builder b;
  addMaterials(b);
  const Sphere sphere(8, 16);
  sphere.addTo(b, 2);  // glow
  sphere.addTo(b, 0);
  b.doc["nodes"] = json::array({node(0, {{"translation", {-2, 0, 0}}}), node(0, {{"translation", {2, 0, 0}}}),
                                node(1, {{"translation", {0, 2, 0}}}), node(1, {{"translation", {0, -2, 0}}}),
                                node(1, {{"scale", {1, 0, 1}}})});
  b.doc["scenes"] = {{{"nodes", {0, 1, 2, 3, 4}}}};
  write(dir, "glow.glb", b.glb());
  const Scene s = test::loadSceneJson(dir, sceneAround("glow.glb", true));
  EXPECT_EQ(s.prototypes.size(), 1u);  // the matte sphere
  EXPECT_EQ(s.instances.size(), 2u);   // (its third node has a zero scale: not drawn)
  size_t emitting = 0;
  for (const TriangleMesh& mesh : s.meshes)
    for (uint32_t id : mesh.materialIds) emitting += s.materials[id].isEmissive() ? 1 : 0;
  EXPECT_EQ(emitting, 2 * sphere.triangles() + 2);  // both glowing spheres, and the quad light
  const auto noted = [&](const std::string& part) {
    for (const std::string& n : s.notes)
      if (n.find(part) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(noted("emits light: copied for each of its 2 uses")) << ::testing::PrintToString(s.notes);
  EXPECT_TRUE(noted("nodes[4]: its world transform has a zero scale")) << ::testing::PrintToString(s.notes);
  // The lights are sampled: both copies are in the light sampler.
  const RenderScene rs(s);
  EXPECT_EQ(rs.lights().size(), 2 * sphere.triangles() + 2);
}

TEST(Instancing, AnInstanceBeyondRenderSpaceIsRefusedByName) {
  test::TempDir dir;
  test::Builder b;
  addMaterials(b);
  Sphere(4, 8).addTo(b, 0);
  b.doc["nodes"] =
      json::array({node(0, {{"name", "near"}}), node(0, {{"name", "runaway"}, {"translation", {1e300, 0, 0}}})});
  b.doc["scenes"] = {{{"nodes", {0, 1}}}};
  write(dir, "runaway.glb", b.glb());
  try {
    test::loadSceneJson(dir, sceneAround("runaway.glb", true));
    FAIL() << "loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("instance \"runaway\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("shapes[0]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lensfarm
