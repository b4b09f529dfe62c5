// Where a scene sits and how big it is must not change its image
// (docs/numerics.md, "Far from the origin", "Scale", "Thin gaps", "Coplanar
// surfaces"): the Cornell scenes (one through a real lens) and a closed furnace moved up to 1e7 along
// each axis or scaled from 1e-6 to 1e10 give the image they give at the origin
// at scale 1; a floor and a shelf 1e-6 of the floor's size apart stay apart
// wherever they are; a light flush with a ceiling is seen alike by every
// estimator.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "common/math/ray_offset.h"
#include "common/render/render_scene.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// Applies f to every position of a scene (camera position and look_at, quad
// corners, inline vertices, the translation of a mesh's transform) and g to
// every length (quad edges, camera lengths, a mesh's scale).
template <typename Position, typename Length>
json mapScene(json scene, Position f, Length g) {
  auto vec = [](const json& v) { return DVec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()); };
  auto put = [](const DVec3& d) { return json::array({d.x, d.y, d.z}); };
  json& cam = scene["camera"];
  cam["position"] = put(f(vec(cam["position"])));
  cam["look_at"] = put(f(vec(cam["look_at"])));
  for (const char* key : {"focal_length", "sensor_width", "sensor_height", "focus_distance", "scene_units_per_mm"})
    if (cam.contains(key)) cam[key] = g(cam[key].get<double>());
  auto quad = [&](json& q) {
    q["corner"] = put(f(vec(q["corner"])));
    for (const char* key : {"edge1", "edge2"})
      q[key] = put(DVec3(g(vec(q[key]).x), g(vec(q[key]).y), g(vec(q[key]).z)));
  };
  for (json& shape : scene["shapes"]) {
    if (shape["type"] == "quad") quad(shape);
    if (shape["type"] == "triangles")
      for (json& v : shape["vertices"]) v = put(f(vec(v)));
    if (shape["type"] == "obj") {
      json& t = shape["transform"];
      t["translate"] = put(f(t.contains("translate") ? vec(t["translate"]) : DVec3(0.0)));
      DVec3 s = t.contains("scale") ? (t["scale"].is_number() ? DVec3(t["scale"].get<double>()) : vec(t["scale"]))
                                    : DVec3(1.0);
      t["scale"] = put(DVec3(g(s.x), g(s.y), g(s.z)));
    }
  }
  if (scene.contains("lights"))
    for (json& light : scene["lights"]) quad(light);
  return scene;
}

json translated(const json& scene, const DVec3& d) {
  return mapScene(
      scene, [&](const DVec3& p) { return p + d; }, [](double x) { return x; });
}
json scaled(const json& scene, double k) {
  return mapScene(
      scene, [&](const DVec3& p) { return p * k; }, [&](double x) { return x * k; });
}

json small(json scene, int size, uint64_t spp) {
  scene["render"]["resolution"] = {size, size};
  scene["render"]["samples_per_pixel"] = spp;
  // The same random numbers trace the same paths up to rounding at every place and scale, which
  // path guiding's learned field turns into other paths (its images agree within noise there:
  // PathGuiding.AgreesFarFromTheOriginAndAtExtremeScales).
  scene["render"]["path_guiding"] = "off";
  return scene;
}

// Albedo 0.5, emission 1, bounce limit 8: without Russian roulette every path carries exactly
// sum_{k=0}^{8} 0.5^k, so a leak of 0.2 % shows (the default roulette's noise would hide it; the
// other scenes keep the default).
json furnace() {
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.5}, {"emission", 1.0}}, 12, 8, 8);
  scene["render"]["russian_roulette"] = "off";
  return scene;
}
constexpr double kFurnaceExact = 1.99609375;

struct Named {
  std::string name;
  json scene;
};
// A shelf 0.2 above a floor, seen from the side through the gap, lit from above: the floor under
// the shelf gets only the light that bounces in (moved by 1e5 it came out ~90x too bright).
json shelf() {
  json scene = test::minimalSceneJson();
  scene["camera"] = {{"type", "pinhole"}, {"position", {0, 0.1, -3}}, {"look_at", {0, 0.1, 0}},
                     {"up", {0, 1, 0}},   {"sensor_width", 0.036},    {"angle_of_view", 30}};
  scene["materials"]["floor"] = {{"type", "lambertian"}, {"albedo", 0.7}};
  scene["shapes"] = json::array(
      {{{"type", "quad"}, {"corner", {-1, 0, -1}}, {"edge1", {0, 0, 2}}, {"edge2", {2, 0, 0}}, {"material", "floor"}},
       {{"type", "quad"},
        {"corner", {-0.5, 0.2, -0.5}},
        {"edge1", {0, 0, 1}},
        {"edge2", {1, 0, 0}},
        {"material", "floor"}}});
  scene["lights"] = json::array({{{"type", "quad"},
                                  {"corner", {-0.25, 1, -0.25}},
                                  {"edge1", {0.5, 0, 0}},
                                  {"edge2", {0, 0, 0.5}},
                                  {"radiance", 8}}});
  return small(scene, 24, 16);
}

std::vector<Named> placementScenes() {
  return {{"cornell-seed", small(test::bundledSceneJson("cornell-seed.json"), 24, 8)},
          {"cornell-classic", small(test::bundledSceneJson("cornell-classic.json"), 24, 8)},
          {"cornell-real-lens", small(test::bundledSceneJson("cornell-real-lens.json"), 24, 8)},
          {"furnace", furnace()},
          {"shelf", shelf()}};
}

double meanOf(const test::Rendered& r) { return (r.mean[0] + r.mean[1] + r.mean[2]) / 3.0; }

// The class's promise: mean within 0.5 % of the reference, and no pixel black
// that is not black in the reference.
void expectSameImage(const test::Rendered& r, const test::Rendered& reference, const std::string& what) {
  EXPECT_EQ(r.stats.dropped, 0u) << what;
  EXPECT_NEAR(meanOf(r) / meanOf(reference), 1.0, 0.005) << what;
  int newlyBlack = 0;
  for (size_t p = 0; p + 2 < r.image.rgb.size(); p += 3) {
    const bool black = r.image.rgb[p] == 0 && r.image.rgb[p + 1] == 0 && r.image.rgb[p + 2] == 0;
    const bool wasBlack =
        reference.image.rgb[p] == 0 && reference.image.rgb[p + 1] == 0 && reference.image.rgb[p + 2] == 0;
    newlyBlack += black && !wasBlack;
  }
  EXPECT_EQ(newlyBlack, 0) << what;
}

TEST(FarFromTheOrigin, TheImageDoesNotDependOnWhereTheSceneSits) {
  test::TempDir dir;
  for (const Named& s : placementScenes()) {
    const test::Rendered reference = test::renderScene(test::loadSceneJson(dir, s.scene));
    if (s.name == "furnace") {
      EXPECT_NEAR(meanOf(reference) / kFurnaceExact, 1.0, 0.002);
    }
    for (double distance : {1e3, 1e5, 1e6, 1e7})
      for (int axis = 0; axis < 3; ++axis) {
        DVec3 d(0.0);
        d[axis] = axis == 1 ? -distance : distance;
        const std::string what =
            s.name + " moved by " + std::to_string(distance) + " along axis " + std::to_string(axis);
        const test::Rendered r = test::renderScene(test::loadSceneJson(dir, translated(s.scene, d)));
        expectSameImage(r, reference, what);
        if (s.name == "furnace") {
          EXPECT_NEAR(meanOf(r) / kFurnaceExact, 1.0, 0.002) << what;
        }
      }
  }
}

TEST(FarFromTheOrigin, SceneIsRecentredOnTheCameraInDoublePrecision) {
  // A vertex 0.3 units from a camera 1e7 from the origin: in float the world
  // coordinates are 1 apart, in render space the offset is exact.
  test::TempDir dir;
  json scene = translated(test::minimalSceneJson(), DVec3(1e7, -1e7, 1e7));
  const Scene s = test::loadSceneJson(dir, scene);
  const DVec3 camera(scene["camera"]["position"][0].get<double>(), scene["camera"]["position"][1].get<double>(),
                     scene["camera"]["position"][2].get<double>());
  EXPECT_EQ(s.origin, camera);
  EXPECT_EQ(s.cameraParams.position, Vec3(0.0f));
  const json& quad = scene["shapes"][0];
  const DVec3 corner(quad["corner"][0].get<double>(), quad["corner"][1].get<double>(), quad["corner"][2].get<double>());
  EXPECT_EQ(s.meshes[0].positions[0], Vec3(corner - camera));
}

TEST(Scale, TheSameSceneFrom1eMinus6To1e10GivesTheSameImage) {
  test::TempDir dir;
  for (const Named& s : placementScenes()) {
    const test::Rendered reference = test::renderScene(test::loadSceneJson(dir, s.scene));
    for (double k : {1e-6, 1e-3, 1e3, 1e6, 1e10}) {
      const std::string what = s.name + " scaled by " + std::to_string(k);
      const Scene loaded = test::loadSceneJson(dir, scaled(s.scene, k));
      EXPECT_EQ(loaded.skippedDegenerateTriangles, 0u) << what;
      const test::Rendered r = test::renderScene(loaded);
      expectSameImage(r, reference, what);
      if (s.name == "furnace") {
        EXPECT_NEAR(meanOf(r) / kFurnaceExact, 1.0, 0.002) << what;
      }
    }
  }
}

TEST(Scale, AHugeQuadIsKeptAndATrulyDegenerateTriangleIsStillCounted) {
  // 1e10-long edges: |cross|^2 = 1e40 overflows float, the area does not.
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  scene["shapes"].push_back({{"type", "quad"},
                             {"corner", {-5e9, -5e9, 3e9}},
                             {"edge1", {1e10, 0, 0}},
                             {"edge2", {0, 1e10, 0}},
                             {"material", "white"}});
  scene["shapes"].push_back(
      {{"type", "triangles"}, {"material", "white"}, {"vertices", {{0, 0, 5}, {1, 1, 5}, {2, 2, 5}}}});  // collinear
  const auto triangles = [](const Scene& s) {
    size_t n = 0;
    for (const auto& m : s.meshes) n += m.triangleCount();
    return n;
  };
  const size_t before = triangles(test::loadSceneJson(dir, test::minimalSceneJson()));
  const Scene s = test::loadSceneJson(dir, scene);
  EXPECT_EQ(s.skippedDegenerateTriangles, 1u);
  EXPECT_EQ(triangles(s), before + 2u);  // the huge quad's two triangles
}

// A floor [-1,1]^2 at y = 0 and a shelf [-0.5,0.5]^2 at y = gap above it, moved
// by `offset` with the camera. Returns how many of `rays` rays leaving the
// floor under the shelf upwards, or the shelf downwards, cross the other
// surface (a leak), and how many shadow rays from the floor to a light above
// the shelf get through.
struct Leaks {
  int crossed = 0, unshadowed = 0;
};
void thinGapLeaks(double gap, const DVec3& offset, int rays, Leaks& leaks) {
  json scene = test::minimalSceneJson();
  scene["camera"]["position"] = {0.3, 2, -3};
  scene["camera"]["look_at"] = {0, 0, 0};
  scene["materials"]["floor"] = {{"type", "lambertian"}, {"albedo", 0.5}};
  scene["materials"]["shelf"] = {{"type", "lambertian"}, {"albedo", 0.5}};
  scene["shapes"] = json::array(
      {{{"type", "quad"}, {"corner", {-1, 0, -1}}, {"edge1", {0, 0, 2}}, {"edge2", {2, 0, 0}}, {"material", "floor"}},
       {{"type", "quad"},
        {"corner", {-0.5, gap, -0.5}},
        {"edge1", {0, 0, 1}},
        {"edge2", {1, 0, 0}},
        {"material", "shelf"}}});
  scene["lights"] = json::array({{{"type", "quad"},
                                  {"corner", {-0.25, 1, -0.25}},
                                  {"edge1", {0.5, 0, 0}},
                                  {"edge2", {0, 0, 0.5}},
                                  {"radiance", 1}}});
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, translated(scene, offset));
  const RenderScene rs(s);
  const Vec3 toRender = Vec3(offset - s.origin);  // render space = world - origin
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < rays; ++k) {
    // A point under the shelf, away from its edges, found as the renderer finds
    // points: by a hit.
    const float x = 0.8f * u(rng) - 0.4f, z = 0.8f * u(rng) - 0.4f;
    const bool fromFloor = k % 2 == 0;
    const Vec3 probe = toRender + Vec3(x, fromFloor ? -1.0f : 0.5f, z);  // the light is at y = 1
    const auto hit = rs.caster().intersect(probe, Vec3(0, fromFloor ? 1 : -1, 0), RayKind::kScattered);
    ASSERT_TRUE(hit && s.materials[hit->material].name == (fromFloor ? "floor" : "shelf")) << "probe " << k;
    const std::string there = fromFloor ? "shelf" : "floor";
    // Leaving into the gap, down to 1e-3 above grazing.
    const float cosTheta = k % 4 < 2 ? 1e-3f + 0.1f * u(rng) : u(rng);
    const float phi = 6.2831853f * u(rng), sinTheta = std::sqrt(1 - cosTheta * cosTheta);
    const Vec3 w(sinTheta * std::cos(phi), fromFloor ? cosTheta : -cosTheta, sinTheta * std::sin(phi));
    const Vec3 o = spawnOrigin(hit->p, hit->plane(), w);
    const auto next = rs.caster().intersect(o, w, RayKind::kScattered);
    if (!next || s.materials[next->material].name != there) {
      // It must meet the other surface of the pair unless it leaves the gap
      // sideways first.
      const Vec3 end = hit->p + (float(gap) / cosTheta) * w;
      if (std::abs(end.x - toRender.x) < 0.5f && std::abs(end.z - toRender.z) < 0.5f) ++leaks.crossed;
    }
    if (fromFloor) {
      const Vec3 light = toRender + Vec3(0.5f * u(rng) - 0.25f, 1.0f, 0.5f * u(rng) - 0.25f);
      const Vec3 from = spawnOrigin(hit->p, hit->plane(), light - hit->p);
      if (!rs.caster().occluded(from, light - from, 1.0f - 1e-4f)) ++leaks.unshadowed;
    }
  }
}

TEST(ThinGaps, AFloorAndAShelfAMillionthOfTheFloorApartLeakNothingWhereverTheySit) {
  for (double gap : {1e-2, 1e-4, 2e-6})  // the floor is 2 across: gap / extent down to 1e-6
    for (double distance : {0.0, 1e3, 1e5, 1e7}) {
      Leaks leaks;
      thinGapLeaks(gap, DVec3(distance, -distance, 0.5 * distance), 20000, leaks);
      EXPECT_EQ(leaks.crossed, 0) << "gap " << gap << " at " << distance;
      EXPECT_EQ(leaks.unshadowed, 0) << "gap " << gap << " at " << distance;
    }
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// A closed room (albedo 0.5) with a light flush with its ceiling: the light's quad lies in the
// ceiling's plane, facing down like it.
json flushLightRoom(const std::string& integrator) {
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.5}}, 16, 16, 3);
  scene["lights"] = json::array({{{"type", "quad"},
                                  {"corner", {-0.3, 1, -0.3}},
                                  {"edge1", {0.6, 0, 0}},
                                  {"edge2", {0, 0, 0.6}},
                                  {"radiance", 4}}});
  scene["camera"]["look_at"] = {0, 0.6, 1};
  scene["render"]["integrator"] = integrator;
  return scene;
}

// The same room with the lamp as a group of an OBJ mesh whose other group is a ceiling panel in
// the same plane (how exporters write a lamp set into a ceiling).
json flushLampGroupRoom(const std::string& integrator) {
  json scene = flushLightRoom(integrator);
  scene["lights"] = json::array();
  scene["materials"]["lamp"] = {{"type", "emissive"}, {"radiance", 4}};
  scene["shapes"].push_back(
      {{"type", "obj"}, {"file", "ceiling.obj"}, {"group_materials", {{"panel", "wall"}, {"lamp", "lamp"}}}});
  return scene;
}
const char* kCeilingObj =
    "g panel\nv -0.6 1 -0.6\nv 0.6 1 -0.6\nv 0.6 1 0.6\nv -0.6 1 0.6\nf 1 2 3 4\n"
    "g lamp\nv -0.3 1 -0.3\nv 0.3 1 -0.3\nv 0.3 1 0.3\nv -0.3 1 0.3\nf 5 6 7 8\n";

TEST(Coplanar, ALampGroupFlushWithItsMeshsCeilingPanelIsSeenAlikeByEveryEstimator) {
  test::TempDir dir;
  dir.write("ceiling.obj", kCeilingObj);
  const test::ImageStatistics naive = test::renderStatistics(test::loadSceneJson(dir, flushLampGroupRoom("naive")), 16);
  ASSERT_GT(naive.imageMean, 0.0);
  const test::ImageStatistics mis = test::renderStatistics(test::loadSceneJson(dir, flushLampGroupRoom("nee_mis")), 16);
  EXPECT_NEAR(mis.imageMean, naive.imageMean, 4 * std::hypot(naive.imageMeanError, mis.imageMeanError))
      << "nee_mis / naive = " << mis.imageMean / naive.imageMean;
}

TEST(Coplanar, ALightFlushWithTheCeilingIsSeenAlikeByEveryEstimator) {
  test::TempDir dir;
  const test::ImageStatistics naive = test::renderStatistics(test::loadSceneJson(dir, flushLightRoom("naive")), 16);
  ASSERT_GT(naive.imageMean, 0.0);
  for (const char* integrator : {"nee", "nee_mis"}) {
    const test::ImageStatistics other =
        test::renderStatistics(test::loadSceneJson(dir, flushLightRoom(integrator)), 16);
    const double error = std::hypot(naive.imageMeanError, other.imageMeanError);
    EXPECT_NEAR(other.imageMean, naive.imageMean, 4 * error)
        << integrator << " / naive = " << other.imageMean / naive.imageMean;
  }
}

// A camera exactly in the plane of a black sheet that surrounds it (the sheet x = 0 through the
// pinhole), in a lit room: every camera ray starts in the sheet. Under the coplanar rule the
// rays leave it, so the camera sees the room; without it every ray hits the sheet at distance 0
// and the image is black.
json cameraInASheet(const std::string& integrator) {
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.5}}, 16, 16, 2);
  scene["materials"]["black"] = {{"type", "lambertian"}, {"albedo", 0.0}};
  scene["shapes"].push_back({{"type", "quad"},
                             {"corner", {0, -0.5, -0.5}},
                             {"edge1", {0, 1, 0}},
                             {"edge2", {0, 0, 1}},
                             {"material", "black"}});
  scene["lights"] = json::array({{{"type", "quad"},
                                  {"corner", {-0.3, 0.99, -0.3}},
                                  {"edge1", {0.6, 0, 0}},
                                  {"edge2", {0, 0, 0.6}},
                                  {"radiance", 4}}});
  scene["camera"]["look_at"] = {0.2, 0.1, 1};
  scene["render"]["integrator"] = integrator;
  return scene;
}

TEST(Coplanar, ACameraInASurfacesPlaneSeesPastItAndEveryEstimatorAgrees) {
  test::TempDir dir;
  const test::Rendered image = test::renderScene(test::loadSceneJson(dir, cameraInASheet("nee_mis")));
  int black = 0;
  for (size_t p = 0; p + 2 < image.image.rgb.size(); p += 3)
    black += image.image.rgb[p] == 0 && image.image.rgb[p + 1] == 0 && image.image.rgb[p + 2] == 0;
  EXPECT_EQ(black, 0);
  const test::ImageStatistics naive = test::renderStatistics(test::loadSceneJson(dir, cameraInASheet("naive")), 16);
  const test::ImageStatistics mis = test::renderStatistics(test::loadSceneJson(dir, cameraInASheet("nee_mis")), 16);
  EXPECT_NEAR(mis.imageMean, naive.imageMean, 4 * std::hypot(naive.imageMeanError, mis.imageMeanError))
      << "nee_mis / naive = " << mis.imageMean / naive.imageMean;
}

}  // namespace
}  // namespace lensfarm
