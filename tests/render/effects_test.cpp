// Simulate only the effects a scene calls for: each effect turns on when the scene needs it and
// off when it does not, and leaving one out changes no bit of the image.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "common/render/unit_renderer.h"
#include "common/scene/effects.h"
#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

json sceneFile(const char* name) { return test::bundledSceneJson(name); }

const EffectDecision& decision(const EffectSet& e, const std::string& effect) {
  for (const auto& d : e.decisions)
    if (d.effect == effect) return d;
  throw std::runtime_error("no decision about " + effect);
}

EffectSet effectsOf(const json& scene) {
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, scene);
  return analyzeEffects(s, s.camera());
}

std::vector<double> unitSums(const Scene& scene, bool general) {
  const RenderScene rs(scene, general);
  SensorBuffer buffer;
  PathStats stats;
  tbb::task_arena arena{2};
  arena.execute([&] { renderUnit(rs, WorkUnit{0, 0, 4}, buffer, stats); });
  return buffer.sums;
}

TEST(Effects, DepthOfFieldFollowsTheAperture) {
  json scene = sceneFile("cornell-seed.json");
  EXPECT_TRUE(effectsOf(scene).depthOfField) << "N = 16 blurs the box's far wall";
  scene["camera"]["f_number"] = "infinity";
  EXPECT_FALSE(effectsOf(scene).depthOfField);
  EXPECT_NE(decision(effectsOf(scene), "depth of field").reason.find("aperture closed"), std::string::npos);
  scene["camera"]["f_number"] = 1e5;  // open, but its blur is far below a pixel
  const EffectSet tiny = effectsOf(scene);
  EXPECT_FALSE(tiny.depthOfField);
  EXPECT_NE(decision(tiny, "depth of field").reason.find("below half a cell"), std::string::npos);
  scene["render"]["resolution"] = {8, 8};
  scene["camera"]["f_number"] = 16;
  EXPECT_FALSE(effectsOf(scene).depthOfField) << "at 8x8 pixels the same blur is below a cell";
}

// The 2013 report's f/16 lens blurs at most ~1.1 cells at 800 x 800: at a preview size the blur falls
// below half a cell and the lens is traced as a pinhole. That changes what the scene asks for,
// so it is a warning (the start of a render logs EffectSet::warnings()), and the job's effects
// (JobInfo.effects, printed by `lensfarm render` and `status`) say it, with the resolution from
// which on depth of field is simulated.
TEST(Effects, DepthOfFieldLeftOutAtAPreviewResolutionIsAWarning) {
  json scene = sceneFile("cornell-seed.json");
  const EffectSet full = effectsOf(scene);
  ASSERT_TRUE(full.depthOfField);
  EXPECT_FALSE(decision(full, "depth of field").changesScene);
  EXPECT_TRUE(full.warnings().empty()) << full.warnings()[0];

  scene["render"]["resolution"] = {200, 200};
  const EffectSet preview = effectsOf(scene);
  EXPECT_FALSE(preview.depthOfField);
  const EffectDecision& d = decision(preview, "depth of field");
  EXPECT_TRUE(d.changesScene);
  for (const char* part : {"f/16", "traced as a pinhole at 200x200 px", "below half a cell", "px on it is simulated"})
    EXPECT_NE(d.reason.find(part), std::string::npos) << "\"" << part << "\" not in: " << d.reason;
  ASSERT_EQ(preview.warnings().size(), 1u);
  EXPECT_EQ(preview.warnings()[0], "depth of field is not simulated: " + d.reason);

  // The resolution it names is where depth of field comes back.
  const size_t from = d.reason.find("from ") + 5;
  const int w = std::stoi(d.reason.substr(from)), h = std::stoi(d.reason.substr(d.reason.find('x', from) + 1));
  scene["render"]["resolution"] = {w, h};
  EXPECT_TRUE(effectsOf(scene).depthOfField) << w << "x" << h;
  scene["render"]["resolution"] = {w - 2, h - 2};
  EXPECT_FALSE(effectsOf(scene).depthOfField) << w - 2 << "x" << h - 2;

  // A pinhole, or a closed aperture, is what the scene asks for: no warning.
  scene["camera"]["f_number"] = "infinity";
  EXPECT_TRUE(effectsOf(scene).warnings().empty());
  json classic = sceneFile("cornell-classic.json");
  classic["render"]["resolution"] = {8, 8};
  EXPECT_TRUE(effectsOf(classic).warnings().empty());
  // An aperture so small that no resolution shows its blur says what to do instead.
  scene["camera"]["f_number"] = 1e7;
  const EffectDecision& tiny = decision(effectsOf(scene), "depth of field");
  EXPECT_TRUE(tiny.changesScene);
  EXPECT_NE(tiny.reason.find("at every resolution up to 16384"), std::string::npos) << tiny.reason;
}

TEST(Effects, TheJobsEffectsListDepthOfFieldLeftOut) {
  json scene = sceneFile("cornell-seed.json");
  scene["render"]["resolution"] = {200, 200};
  const std::string mesh = scene["shapes"][0]["file"];
  const std::string bytes = test::readFile(mesh);
  Coordinator coordinator;
  coordinator.putAsset(sha256Hex(bytes), bytes);
  JobSpec spec;
  spec.sceneName = "cornell-seed.json";
  spec.sceneJson = scene.dump();
  spec.assets[mesh] = sha256Hex(bytes);
  const JobInfo job = coordinator.submit(spec, 0);
  std::string all;
  for (const auto& e : job.effects) all += e + "\n";
  EXPECT_NE(all.find("depth of field: off (the scene's f/16 lens is traced as a pinhole at 200x200 px"),
            std::string::npos)
      << all;
}

TEST(Effects, BlurEstimateMatchesTheThinLensFormula) {
  // A point at distance D images at S2' = fD/(D-f); its blur on the sensor is 2R|S2'-S2|/S2'.
  json scene = sceneFile("cornell-seed.json");
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, scene);
  const ThinLensCamera camera = s.camera();
  const double f = 0.095, s2 = 1.0 / (1.0 / f - 1.0 / 2.9), r = f / 32.0, cell = 0.1 / 800;
  const auto blur = [&](double d) {
    const double s2d = f * d / (d - f);
    return 2 * r * std::abs(s2d - s2) / s2d / cell;
  };
  // The scene's depth range: the light's front edge (z = -1.5) to the back wall (z = +1).
  const double expected = std::max(blur(2.9 - 1.5), blur(2.9 + 1.0));
  EXPECT_NEAR(maxBlurInCells(s, camera), expected, 1e-6 * expected);
  EXPECT_GT(maxBlurInCells(s, camera), 1.0);
}

TEST(Effects, ReportsWhetherTheCameraSeesALight) {
  EXPECT_TRUE(decision(effectsOf(sceneFile("cornell-classic.json")), "lights seen by the camera").simulated);
  EXPECT_FALSE(decision(effectsOf(sceneFile("cornell-seed.json")), "lights seen by the camera").simulated)
      << "the seed's light is hidden from the camera (§4.4)";
}

TEST(Effects, SpecularOnlyWhenAMirrorIsThere) {
  EXPECT_TRUE(effectsOf(sceneFile("cornell-seed.json")).specular);
  const EffectSet classic = effectsOf(sceneFile("cornell-classic.json"));
  EXPECT_FALSE(classic.specular);
  EXPECT_EQ(decision(classic, "specular reflection").reason, "no mirror in the scene");
}

// A closed cube (shared vertices, every edge on two faces) around a small mirror.
json sealedMirrorScene(const test::TempDir& dir, bool closed, const std::vector<double>& cameraAt) {
  std::string obj =
      "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n"
      "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
      "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 7 3\nf 4 8 7\nf 1 5 8\nf 1 8 4\n";
  if (closed) obj += "f 2 3 7\nf 2 7 6\n";  // without these two, the cube is open on one side
  dir.write("cube.obj", obj);
  json scene = test::minimalSceneJson();
  scene["materials"]["mirror"] = {{"type", "mirror"}};
  scene["camera"]["position"] = cameraAt;
  scene["shapes"].push_back({{"type", "obj"}, {"file", "cube.obj"}, {"material", "white"}});
  scene["shapes"].push_back({{"type", "quad"},
                             {"corner", {-0.1, -0.1, 0}},
                             {"edge1", {0.2, 0, 0}},
                             {"edge2", {0, 0.2, 0}},
                             {"material", "mirror"}});
  return scene;
}

TEST(Effects, AMirrorNoRayCanReachIsNotSimulated) {
  test::TempDir dir;
  const EffectSet sealed = [&] {
    const Scene s = test::loadSceneJson(dir, sealedMirrorScene(dir, true, {0, 0, -3}), "sealed.json");
    return analyzeEffects(s, s.camera());
  }();
  EXPECT_FALSE(sealed.specular);
  EXPECT_NE(decision(sealed, "specular reflection").reason.find("sealed inside a closed mesh"), std::string::npos);
  const Scene open = test::loadSceneJson(dir, sealedMirrorScene(dir, false, {0, 0, -3}), "open.json");
  EXPECT_TRUE(analyzeEffects(open, open.camera()).specular) << "an open box lets rays in";
  const Scene inside = test::loadSceneJson(dir, sealedMirrorScene(dir, true, {0.2, 0.2, -0.3}), "inside.json");
  EXPECT_TRUE(analyzeEffects(inside, inside.camera()).specular) << "the camera is in the box with the mirror";
  // A closed box that lets paths through is no wall: glass, a medium's interface, subsurface.
  for (const json& wall :
       {json{{"type", "dielectric"}, {"ior", 1.5}}, json{{"type", "interface"}, {"interior_medium", "fog"}},
        json{{"type", "subsurface"}, {"mean_free_path", 0.1}}}) {
    json scene = sealedMirrorScene(dir, true, {0, 0, -3});
    scene["media"] = {{"fog", {{"sigma_s", 0.1}}}};
    scene["materials"]["wall"] = wall;
    scene["shapes"][1]["material"] = "wall";
    const Scene s = test::loadSceneJson(dir, scene, "transmitting.json");
    EXPECT_TRUE(analyzeEffects(s, s.camera()).specular) << wall;
  }
  // Leaving the sealed mirror out changes no bit.
  const Scene s = test::loadSceneJson(dir, sealedMirrorScene(dir, true, {0, 0, -3}), "sealed.json");
  const std::vector<double> specialised = unitSums(s, false), general = unitSums(s, true);
  EXPECT_EQ(0, std::memcmp(specialised.data(), general.data(), general.size() * sizeof(double)));
}

TEST(Effects, LightSamplingOnlyWhenALightCanLightSomething) {
  json scene = test::minimalSceneJson();
  EXPECT_TRUE(effectsOf(scene).lightSampling);
  scene["render"]["integrator"] = "naive";
  EXPECT_FALSE(effectsOf(scene).lightSampling);
  scene["render"]["integrator"] = "nee_mis";
  // The minimal scene's light faces +z, towards the quad; turned to face -z, away from the quad
  // and from the camera's side... the camera at z = -3 is in front of it, so it still counts.
  scene["lights"][0]["edge1"] = {0, 1, 0};
  scene["lights"][0]["edge2"] = {1, 0, 0};
  EXPECT_TRUE(effectsOf(scene).lightSampling) << "the camera sees its front";
  // Moved behind the camera and facing away from everything: it lights nothing.
  scene["lights"][0]["corner"] = {-0.5, -0.5, -5};
  const EffectSet away = effectsOf(scene);
  EXPECT_FALSE(away.lightSampling);
  EXPECT_NE(away.summary().find("face away from every surface"), std::string::npos) << away.summary();
}

// The faces of an OBJ reversed: its triangles face the other way.
std::string reversedFaces(const std::string& obj) {
  std::istringstream in(obj);
  std::string out, line;
  while (std::getline(in, line)) {
    if (line.rfind("f ", 0) == 0) {
      std::istringstream f(line.substr(2));
      std::vector<std::string> v;
      for (std::string x; f >> x;) v.push_back(x);
      line = "f";
      for (auto it = v.rbegin(); it != v.rend(); ++it) line += " " + *it;
    }
    out += line + "\n";
  }
  return out;
}

TEST(Effects, ALightThatEmitsNothingIntoTheSceneIsAWarning) {
  const std::string why = ": it emits nothing into the scene (flip its winding or set two_sided)";
  // A light quad behind the camera facing away from everything.
  json scene = test::minimalSceneJson();
  scene["lights"][0]["name"] = "lamp";
  scene["lights"][0]["corner"] = {-0.5, -0.5, -5};
  scene["lights"][0]["edge1"] = {0, 1, 0};
  scene["lights"][0]["edge2"] = {1, 0, 0};
  const EffectSet away = effectsOf(scene);
  ASSERT_EQ(away.warnings().size(), 1u);
  EXPECT_EQ(away.warnings()[0], "light \"lamp\" faces away from every surface and the camera" + why);
  scene["lights"][0]["two_sided"] = true;
  EXPECT_TRUE(effectsOf(scene).warnings().empty());

  // An emissive sphere wound inwards lights only its own inside, where nothing is: it renders
  // black, and is neither sampled nor counted. Wound outwards, it lights the scene, though the
  // triangles at its top face nothing: it is sampled whole.
  test::TempDir dir;
  const std::string sphere = test::sphereObj(8, 16);
  dir.write("inward.obj", reversedFaces(sphere));
  dir.write("outward.obj", sphere);
  for (const char* file : {"inward.obj", "outward.obj"}) {
    SCOPED_TRACE(file);
    json glow = test::minimalSceneJson();
    glow["lights"] = json::array();
    glow["materials"]["glow"] = {{"type", "emissive"}, {"radiance", 3}};
    glow["shapes"].push_back({{"type", "obj"},
                              {"name", "ball"},
                              {"file", file},
                              {"material", "glow"},
                              {"transform", {{"scale", 0.5}, {"translate", {0, 2, -1}}}}});
    const Scene s = test::loadSceneJson(dir, glow);
    const EffectSet e = analyzeEffects(s, s.camera());
    const RenderScene rs(s);
    if (std::string(file) == "inward.obj") {
      ASSERT_EQ(e.warnings().size(), 1u);
      EXPECT_EQ(e.warnings()[0],
                "emissive material \"glow\" (shape \"ball\") faces only into the closed mesh it lies "
                "on, where neither the camera nor any other surface is" +
                    why);
      EXPECT_FALSE(e.lightSampling);
      EXPECT_EQ(rs.lights().size(), 0u);
    } else {
      EXPECT_TRUE(e.warnings().empty()) << e.warnings()[0];
      EXPECT_TRUE(e.lightSampling);
      EXPECT_EQ(rs.lights().size(), 8u * 16u * 2u - 2u * 16u);  // every triangle of the sphere
    }
  }
}

TEST(Effects, SpecialisedAndGeneralPathsGiveTheSameBits) {
  // Where the sampling is the same (no effect approximated), leaving an absent effect out of the
  // compiled path must not change a bit.
  // Combinations: classic (no lens, no mirror), cornell-seed at N = 2 (everything), cornell-seed as a pinhole
  // (mirror, no lens).
  for (const auto& [name, fNumber] : std::vector<std::pair<const char*, json>>{
           {"cornell-classic.json", json()}, {"cornell-seed.json", json(2)}, {"cornell-seed.json", json("infinity")}}) {
    for (const char* integrator : {"nee_mis", "naive"}) {
      json scene = sceneFile(name);
      if (!fNumber.is_null()) scene["camera"]["f_number"] = fNumber;
      scene["render"]["resolution"] = {40, 32};
      scene["render"]["integrator"] = integrator;
      test::TempDir dir;
      const Scene s = test::loadSceneJson(dir, scene);
      const std::vector<double> specialised = unitSums(s, false), general = unitSums(s, true);
      ASSERT_EQ(specialised.size(), general.size());
      EXPECT_EQ(0, std::memcmp(specialised.data(), general.data(), general.size() * sizeof(double)))
          << name << " N " << fNumber << " " << integrator;
    }
  }
}

TEST(Effects, SkippingANegligibleBlurChangesTheImageOnlyWithinNoise) {
  json scene = sceneFile("cornell-seed.json");
  scene["camera"]["f_number"] = 1e5;
  scene["render"]["resolution"] = {32, 32};
  scene["render"]["samples_per_pixel"] = 16;
  // The two cameras trace the same paths up to rounding, which path guiding's field (trained through
  // each camera) would turn into other paths.
  scene["render"]["path_guiding"] = "off";
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, scene);
  const std::vector<double> pinhole = unitSums(s, false), lens = unitSums(s, true);
  double diff = 0, total = 0;
  for (size_t k = 0; k < lens.size(); ++k) {
    diff += std::abs(pinhole[k] - lens[k]);
    total += lens[k];
  }
  EXPECT_LT(diff / total, 1e-3) << "a blur far below a pixel is invisible";
}

}  // namespace
}  // namespace lensfarm
