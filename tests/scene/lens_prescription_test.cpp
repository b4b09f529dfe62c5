// JSON lens prescriptions (scene/lens_prescription.h): the double-Gauss written as JSON is the
// same lens as its pbrt-v4 file (the same first-order figures and the same traced rays, bit for
// bit), inline in a scene or as a .json lens file; aspheric fields reach the surface; and every
// bad field is refused naming its path.
#include "common/scene/lens_prescription.h"

#include <gtest/gtest.h>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The double-Gauss's pbrt-v4 lines turned into JSON surfaces here.
json doubleGaussJson() {
  const LensSystem dat =
      LensSystem::parsePbrt(test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"), "dgauss.50mm.dat");
  json surfaces = json::array();
  for (const LensSurface& s : dat.surfaces()) {
    json j = {{"radius", s.radius}, {"thickness", s.thickness}, {"aperture", s.aperture}};
    if (s.stop)
      j["stop"] = true;
    else
      j["index"] = s.index, j["abbe"] = s.abbe;
    surfaces.push_back(j);
  }
  return {{"name", "double-Gauss 50 mm"}, {"focal_length", 50}, {"surfaces", surfaces}};
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(LensPrescription, TheDoubleGaussAsJsonIsTheSameLensAsItsPbrtFile) {
  const LensSystem dat =
      LensSystem::parsePbrt(test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"), "dgauss.50mm.dat");
  const LensPrescription j = readLensFile(doubleGaussJson().dump(2), "dgauss.json");
  EXPECT_EQ(j.name, "double-Gauss 50 mm");
  ASSERT_TRUE(j.focalLength);
  EXPECT_EQ(*j.focalLength, 50.0);
  EXPECT_EQ(j.system.paraxial().efl, dat.paraxial().efl);
  EXPECT_EQ(j.system.stopIndex(), dat.stopIndex());
  const LensRay ray{DVec3(0.3, 5.0, -10.0), glm::normalize(DVec3(0.0, -0.1, 1.0))};
  const auto a = dat.traceFromObjectSide(ray), b = j.system.traceFromObjectSide(ray);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->origin, b->origin);
  EXPECT_EQ(a->direction, b->direction);
}

TEST(LensPrescription, AsphericFieldsReachTheSurface) {
  json lens = doubleGaussJson();
  lens["surfaces"][0]["conic"] = -0.5;
  lens["surfaces"][0]["aspheric"] = {1e-6, -2e-9};
  const LensPrescription p = lensFromJson(lens, "camera.lens", "scene.json");
  EXPECT_EQ(p.system.surfaces()[0].conic, -0.5);
  EXPECT_EQ(p.system.surfaces()[0].aspheric, (std::vector<double>{1e-6, -2e-9}));
  EXPECT_FALSE(p.system.surfaces()[0].spherical());
}

TEST(LensPrescription, BadFieldsAreRefusedNamingTheirPath) {
  const auto bad = [](const std::function<void(json&)>& edit) {
    json lens = doubleGaussJson();
    edit(lens);
    return errorOf([&] { lensFromJson(lens, "camera.lens", "scene.json"); });
  };
  const auto names = [](const std::string& message, const std::string& field) {
    return message.find(field) != std::string::npos;
  };
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][3]["radius"] = "big"; }), "camera.lens.surfaces[3].radius"));
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][3]["aperture"] = 500; }), "camera.lens.surfaces[3].aperture"));
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][2]["thickness"] = -1; }), "camera.lens.surfaces[2].thickness"));
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][1]["index"] = 0.5; }), "camera.lens.surfaces[1].index"));
  EXPECT_TRUE(names(bad([](json& l) {
                      l["surfaces"][1]["aspheric"] = {1, "x"};
                    }),
                    "camera.lens.surfaces[1].aspheric[1]"));
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][0]["conic"] = 50; }), "camera.lens.surfaces[0].aperture"))
      << "an oblate conic closing inside the clear aperture";
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"][0]["radious"] = 5; }), "camera.lens.surfaces[0].radious"));
  EXPECT_TRUE(names(bad([](json& l) { l["surfaces"] = json::array(); }), "camera.lens.surfaces"));
  EXPECT_TRUE(names(bad([](json& l) { l["focal_length"] = -3; }), "camera.lens.focal_length"));
  EXPECT_TRUE(names(bad([](json& l) {
                      for (json& s : l["surfaces"]) s.erase("stop");
                    }),
                    "exactly one aperture stop"));
  EXPECT_TRUE(names(errorOf([] { readLensFile("{\"surfaces\": [", "broken.json"); }), "broken.json"));
}

TEST(LensPrescription, ASceneTakesTheLensInlineOrAsAJsonFile) {
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-real-lens.json");
  scene["camera"]["lens"] = (test::scenesDir() / "lenses/dgauss.50mm.dat").string();
  const Scene fromDat = test::loadSceneJson(dir, scene);
  scene["camera"]["lens"] = doubleGaussJson();
  const Scene inlined = test::loadSceneJson(dir, scene);
  scene["camera"]["lens"] = dir.write("dgauss.json", doubleGaussJson().dump()).string();
  const Scene fromJson = test::loadSceneJson(dir, scene);
  for (const Scene* s : {&inlined, &fromJson}) {
    EXPECT_EQ(s->cameraParams.focalLength, fromDat.cameraParams.focalLength);
    EXPECT_EQ(s->realLensCamera()->filmZ(), fromDat.realLensCamera()->filmZ());
  }
  scene["camera"]["lens"] = doubleGaussJson();
  scene["camera"]["lens"]["surfaces"][4]["radius"] = 1.0;
  EXPECT_NE(errorOf([&] { test::loadSceneJson(dir, scene); }).find("camera.lens.surfaces[4].aperture"),
            std::string::npos)
      << errorOf([&] { test::loadSceneJson(dir, scene); });
}

}  // namespace
}  // namespace lensfarm
