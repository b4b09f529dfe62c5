// Scenes written the way other tools write them render as their authors made them. Each model is
// written here twice, as a glTF 2.0 file in the forms exporters produce (Blender's among them)
// and as its lensfarm JSON twin built from the specifications' definitions, and the two are
// rendered and compared within noise: a Cornell box whose walls are glTF's exactly-Lambertian
// material, photometric lamps beside emitters, solid and thin glTF glass. Framing and glTF
// cameras are checked geometrically, against the pinhole formula.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "common/light/light_source.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;
using test::Builder;

constexpr double kPi = std::numbers::pi;

struct Quad {
  DVec3 corner, e1, e2;  // faces cross(e1, e2), as a lensfarm quad
};

// Quads as one glTF mesh primitive (4 vertices, 2 triangles each, wound as lensfarm's quads).
int addQuads(Builder& b, const std::vector<Quad>& quads, int material) {
  std::vector<float> p;
  std::vector<uint16_t> idx;
  for (const Quad& q : quads) {
    const uint16_t base = uint16_t(p.size() / 3);
    for (const DVec3& v : {q.corner, q.corner + q.e1, q.corner + q.e1 + q.e2, q.corner + q.e2})
      p.insert(p.end(), {float(v.x), float(v.y), float(v.z)});
    idx.insert(idx.end(), {base, uint16_t(base + 1), uint16_t(base + 2), base, uint16_t(base + 2), uint16_t(base + 3)});
  }
  json primitive = {
      {"attributes", {{"POSITION", b.floats(p, "VEC3")}}}, {"indices", b.indices(idx)}, {"material", material}};
  if (!b.doc.contains("meshes")) b.doc["meshes"] = json::array();
  return b.add("meshes", {{"primitives", json::array({primitive})}});
}

json jsonQuads(const std::vector<Quad>& quads, const std::string& material) {
  json shapes = json::array();
  for (const Quad& q : quads)
    shapes.push_back({{"type", "quad"},
                      {"material", material},
                      {"corner", {q.corner.x, q.corner.y, q.corner.z}},
                      {"edge1", {q.e1.x, q.e1.y, q.e1.z}},
                      {"edge2", {q.e2.x, q.e2.y, q.e2.z}}});
  return shapes;
}

// An axis-aligned box [lo, hi] as six outward quads.
std::vector<Quad> boxQuads(DVec3 lo, DVec3 hi) {
  const DVec3 d = hi - lo;
  const DVec3 x(d.x, 0, 0), y(0, d.y, 0), z(0, 0, d.z);
  return {{lo, y, x}, {lo + z, x, y}, {lo, z, y}, {lo + x, y, z}, {lo, x, z}, {lo + y, z, x}};
}

// glTF's exactly Lambertian surface: metallic 0, roughness 1, and KHR_materials_specular's
// specularFactor 0 (no specular layer), as exporters write a diffuse material.
json lambertianGltf(const std::string& name, DVec3 c) {
  return {{"name", name},
          {"pbrMetallicRoughness",
           {{"baseColorFactor", {c.x, c.y, c.z, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
          {"extensions", {{"KHR_materials_specular", {{"specularFactor", 0.0}}}}}};
}

json vec(DVec3 v) { return {v.x, v.y, v.z}; }

// A glTF node's rotation [x, y, z, w] turning -z (where glTF cameras look) to `forward`, about y.
json yawTowards(DVec3 forward) {
  const double angle = std::atan2(-forward.x, -forward.z);  // rotation about +y taking -z to forward
  return {0.0, std::sin(angle / 2), 0.0, std::cos(angle / 2)};
}

Scene loadModel(const test::TempDir& dir, const Builder& b, const std::string& name, int w, int h, uint64_t spp = 8,
                int bounces = 4) {
  const std::filesystem::path file = dir.write(name, b.embedded());
  std::string text;
  Scene s = modelScene(file, text);
  s.render.width = w, s.render.height = h;
  s.render.samplesPerPixel = spp;
  s.render.maxBounces = bounces;
  return s;
}

// ---- framing and cameras --------------------------------------------------------------------

// Where a world point lands on the image, in pixels from the top left, by the pinhole formula on
// the camera's own frame (its sensor at S2 behind the lens).
Vec2 project(const Scene& s, DVec3 world) {
  const ThinLensCamera c = s.camera();
  const DVec3 d = world - s.origin;
  const double z = glm::dot(d, DVec3(c.forward())), x = glm::dot(d, DVec3(c.right())), y = glm::dot(d, DVec3(c.up()));
  const ThinLensParams& p = c.params();
  const double u = (x / z) * c.imageDistance() / p.sensorWidth, v = (y / z) * c.imageDistance() / p.sensorHeight;
  return Vec2(float((0.5 + u) * c.width()), float((0.5 - v) * c.height()));
}

TEST(OtherTools, AModelWithoutACameraIsFramedWholeAtEveryAspect) {
  // A box 4 wide, 1 high and 0.5 deep: wide models are what a horizontal angle crops at 9:16,
  // tall ones what it crops at 16:9. Both are checked by projecting the box's corners.
  const test::TempDir dir;
  for (const DVec3 size : {DVec3(4, 1, 0.5), DVec3(0.5, 4, 0.5), DVec3(1, 1, 1)}) {
    Builder b;
    b.doc["materials"] = {lambertianGltf("grey", DVec3(0.6))};
    addQuads(b, boxQuads(DVec3(10, -3, 2), DVec3(10, -3, 2) + size), 0);
    b.doc["nodes"] = {{{"mesh", 0}}};
    for (const auto& [w, h] : {std::pair{160, 90}, std::pair{90, 160}, std::pair{64, 64}}) {
      const Scene s = loadModel(dir, b, "box.gltf", w, h);
      for (int k = 0; k < 8; ++k) {
        const DVec3 corner = DVec3(10, -3, 2) + DVec3(k & 1 ? size.x : 0, k & 2 ? size.y : 0, k & 4 ? size.z : 0);
        const Vec2 at = project(s, corner);
        EXPECT_TRUE(at.x > 0.0f && at.x < float(w) && at.y > 0.0f && at.y < float(h))
            << "corner " << k << " of a " << size.x << "x" << size.y << " box at " << w << "x" << h << " lands at "
            << at.x << ", " << at.y;
      }
    }
  }
}

TEST(OtherTools, AFramedModelShowsNoPartCutAtTheImageEdges) {
  // Rendered: the border pixels see only the background (the studio fill, radiance 0.15); the
  // centre sees the model.
  const test::TempDir dir;
  Builder b;
  b.doc["materials"] = {lambertianGltf("grey", DVec3(0.6))};
  addQuads(b, boxQuads(DVec3(-2, -0.5, -0.25), DVec3(2, 0.5, 0.25)), 0);
  b.doc["nodes"] = {{{"mesh", 0}}};
  for (const auto& [w, h] : {std::pair{96, 54}, std::pair{54, 96}}) {
    const test::Rendered r = test::renderScene(loadModel(dir, b, "bar.gltf", w, h, 1, 1));
    const auto at = [&](int x, int y) { return r.image.rgb[3 * (size_t(y) * w + x)]; };
    for (int x = 0; x < w; ++x) EXPECT_FLOAT_EQ(at(x, 0), 0.15f) << w << "x" << h << " top row, x " << x;
    for (int x = 0; x < w; ++x) EXPECT_FLOAT_EQ(at(x, h - 1), 0.15f) << w << "x" << h << " bottom row, x " << x;
    for (int y = 0; y < h; ++y) EXPECT_FLOAT_EQ(at(0, y), 0.15f) << w << "x" << h << " left column, y " << y;
    for (int y = 0; y < h; ++y) EXPECT_FLOAT_EQ(at(w - 1, y), 0.15f) << w << "x" << h << " right column, y " << y;
    EXPECT_NE(at(w / 2, h / 2), 0.15f);
  }
}

TEST(OtherTools, AGltfCameraSeesItsYfovVerticallyAtAnyAspect) {
  // glTF 2.0 §3.10.2: yfov is the vertical field of view; without aspectRatio the viewport's is
  // used, and with one that differs from the image the vertical angle is still yfov. A point at
  // a known angle projects where the pinhole formula puts it, to a tenth of a pixel.
  const test::TempDir dir;
  const double yfov = 0.66;  // the Duck's is 0.6605
  for (const json& aspect : {json(nullptr), json(1.5), json(1.0)}) {
    Builder b;
    b.doc["materials"] = {lambertianGltf("grey", DVec3(0.6))};
    addQuads(b, boxQuads(DVec3(-1, -1, -1), DVec3(1, 1, 1)), 0);
    json perspective = {{"yfov", yfov}, {"znear", 0.1}};
    if (!aspect.is_null()) perspective["aspectRatio"] = aspect;
    b.doc["cameras"] = {{{"type", "perspective"}, {"perspective", perspective}}};
    const DVec3 eye(3, 1, 7), forward = glm::normalize(DVec3(-0.3, 0, -1));
    b.doc["nodes"] = {{{"mesh", 0}}, {{"camera", 0}, {"translation", vec(eye)}, {"rotation", yawTowards(forward)}}};
    for (const auto& [w, h] : {std::pair{1280, 720}, std::pair{720, 1280}, std::pair{500, 500}}) {
      const Scene s = loadModel(dir, b, "cam.gltf", w, h);
      const DVec3 right = glm::normalize(glm::cross(forward, DVec3(0, 1, 0))), up(0, 1, 0);
      // Points at a quarter and at the full half-angle above and right of the axis, 5 units out.
      const double t = std::tan(yfov / 2), aspectOf = double(w) / h;
      for (const double frac : {0.25, 0.5, 0.999}) {
        const DVec3 p = eye + 5.0 * (forward + frac * t * up + frac * t * aspectOf * right);
        const Vec2 at = project(s, p);
        EXPECT_NEAR(at.y, h / 2.0 * (1.0 - frac), 0.1) << "aspectRatio " << aspect << " at " << w << "x" << h;
        EXPECT_NEAR(at.x, w / 2.0 * (1.0 + frac), 0.1) << "aspectRatio " << aspect << " at " << w << "x" << h;
      }
    }
  }
}

// ---- a Cornell box written as glTF against its JSON twin --------------------------------------

struct CornellBox {
  std::vector<Quad> white, red, green, block, light;
  DVec3 eye{0, 1, 3.4};
  double yfov = 0.6;
  CornellBox() {
    // A 2 x 2 x 2 room open towards +z, inward-facing walls; a block on the floor; a light just
    // under the ceiling facing down.
    white = {{DVec3(-1, 0, -1), DVec3(0, 0, 2), DVec3(2, 0, 0)} /* floor, up */,
             {DVec3(-1, 2, -1), DVec3(2, 0, 0), DVec3(0, 0, 2)} /* ceiling, down */,
             {DVec3(-1, 0, -1), DVec3(2, 0, 0), DVec3(0, 2, 0)} /* back, +z */};
    red = {{DVec3(-1, 0, -1), DVec3(0, 2, 0), DVec3(0, 0, 2)}};   // left, +x
    green = {{DVec3(1, 0, -1), DVec3(0, 0, 2), DVec3(0, 2, 0)}};  // right, -x
    block = boxQuads(DVec3(-0.1, 0, -0.5), DVec3(0.5, 0.6, 0.1));
    light = {{DVec3(-0.25, 1.99, -0.25), DVec3(0.5, 0, 0), DVec3(0, 0, 0.5)}};  // faces -y
  }
};

TEST(OtherTools, ACornellBoxWrittenAsGltfRendersAsItsJsonTwin) {
  const CornellBox box;
  const test::TempDir dir;
  const DVec3 radiance(12, 9, 4);
  Builder b;
  b.doc["extensionsUsed"] = {"KHR_materials_specular", "KHR_materials_emissive_strength"};
  b.doc["materials"] = {lambertianGltf("white", DVec3(0.75)),
                        lambertianGltf("red", DVec3(0.75, 0.15, 0.15)),
                        lambertianGltf("green", DVec3(0.15, 0.75, 0.15)),
                        // An emitter that reflects nothing: black base, no specular layer; its
                        // radiance as emissiveFactor x emissiveStrength.
                        {{"name", "light"},
                         {"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 0, 1}}, {"metallicFactor", 0.0}}},
                         {"emissiveFactor", {1.0, 0.75, 1.0 / 3.0}},
                         {"extensions",
                          {{"KHR_materials_emissive_strength", {{"emissiveStrength", 12.0}}},
                           {"KHR_materials_specular", {{"specularFactor", 0.0}}}}}}};
  std::vector<Quad> whites = box.white;
  whites.insert(whites.end(), box.block.begin(), box.block.end());
  addQuads(b, whites, 0);
  addQuads(b, box.red, 1);
  addQuads(b, box.green, 2);
  addQuads(b, box.light, 3);
  b.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", box.yfov}, {"znear", 0.1}}}}};
  b.doc["nodes"] = {
      {{"mesh", 0}}, {{"mesh", 1}}, {{"mesh", 2}}, {{"mesh", 3}}, {{"camera", 0}, {"translation", vec(box.eye)}}};
  Scene gltf = loadModel(dir, b, "cornell.gltf", 48, 48, 16, 3);

  json twin = {{"format", "lensfarm-scene/1"},
               {"render", {{"resolution", {48, 48}}, {"samples_per_pixel", 16}, {"max_bounces", 3}}},
               {"camera",
                {{"type", "pinhole"},
                 {"position", vec(box.eye)},
                 {"look_at", vec(box.eye + DVec3(0, 0, -1))},
                 {"angle_of_view", box.yfov * 180.0 / kPi},
                 {"fov_axis", "vertical"}}},
               {"materials",
                {{"white", {{"type", "lambertian"}, {"albedo", 0.75}}},
                 {"red", {{"type", "lambertian"}, {"albedo", {0.75, 0.15, 0.15}}}},
                 {"green", {{"type", "lambertian"}, {"albedo", {0.15, 0.75, 0.15}}}}}},
               {"shapes", json::array()},
               {"lights",
                {{{"type", "quad"},
                  {"corner", vec(box.light[0].corner)},
                  {"edge1", vec(box.light[0].e1)},
                  {"edge2", vec(box.light[0].e2)},
                  {"radiance", vec(radiance)}}}}};
  for (const auto& [quads, material] : {std::pair{&box.white, "white"}, std::pair{&box.block, "white"},
                                        std::pair{&box.red, "red"}, std::pair{&box.green, "green"}})
    for (const json& q : jsonQuads(*quads, material)) twin["shapes"].push_back(q);
  const Scene fromJson = test::loadSceneJson(dir, twin);

  // The light's edges land on the same rows in both (the pinhole projection, no one-row shift).
  const Vec2 edgeG = project(gltf, box.light[0].corner), edgeJ = project(fromJson, box.light[0].corner);
  EXPECT_NEAR(edgeG.x, edgeJ.x, 1e-3);
  EXPECT_NEAR(edgeG.y, edgeJ.y, 1e-3);
  test::expectSameImage(test::renderStatistics(gltf, 16), test::renderStatistics(fromJson, 16));
}

// ---- photometric lamps beside emitters --------------------------------------------------------

TEST(OtherTools, ABlenderStyleLampKeepsItsBalanceWithAnEmitter) {
  // Blender's exporter writes a lamp of P watts as P / (4 pi) x 683 candela and an emitter's
  // strength as it is: a 500 W spot is 27,175.7 cd. Rendered against its radiometric twin (the
  // model without the lamp, and the lamp in the scene as P / (4 pi) W/sr), the balance of lamp
  // and emitter is the same.
  const test::TempDir dir;
  const double watts = 500.0, candela = watts / (4.0 * kPi) * 683.0;
  EXPECT_NEAR(candela, 27175.7, 0.05);
  Builder b;
  b.doc["extensionsUsed"] = {"KHR_lights_punctual", "KHR_materials_emissive_strength"};
  b.doc["materials"] = {lambertianGltf("floor", DVec3(0.6)),
                        {{"name", "glow"},
                         {"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 0, 1}}, {"metallicFactor", 0.0}}},
                         {"emissiveFactor", {1.0, 0.4, 0.1}},
                         {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 5.0}}}}}}};
  addQuads(b, {{DVec3(-5, 0, -5), DVec3(0, 0, 10), DVec3(10, 0, 0)}}, 0);
  addQuads(b, {{DVec3(-0.5, 0.01, -0.5), DVec3(0, 0, 1), DVec3(1, 0, 0)}}, 1);
  const double half = 0.3;  // the camera looks 0.6 rad down: [sin(-0.3), 0, 0, cos(-0.3)] about x
  b.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 1.0}, {"znear", 0.1}}}}};
  b.doc["nodes"] = {{{"mesh", 0}},
                    {{"mesh", 1}},
                    {{"camera", 0}, {"translation", {0, 4, 6}}, {"rotation", {-std::sin(half), 0, 0, std::cos(half)}}}};
  const std::filesystem::path withoutLamp = dir.write("room.gltf", b.embedded());

  // The lamp, pointing down (-z turned -90 degrees about x), added to the model as Blender would.
  b.doc["extensions"] = {
      {"KHR_lights_punctual",
       {{"lights",
         {{{"type", "spot"}, {"intensity", candela}, {"spot", {{"innerConeAngle", 0.3}, {"outerConeAngle", 0.6}}}}}}}}};
  b.doc["nodes"].push_back({{"translation", {2, 3, 0}},
                            {"rotation", {-std::sin(kPi / 4), 0, 0, std::cos(kPi / 4)}},
                            {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  const Scene gltf = loadModel(dir, b, "lamp.gltf", 40, 30, 16, 2);
  ASSERT_EQ(gltf.lights.size(), 1u);

  const json twin = {{"format", "lensfarm-scene/1"},
                     {"render", {{"resolution", {40, 30}}, {"samples_per_pixel", 16}, {"max_bounces", 2}}},
                     {"shapes", {{{"type", "gltf"}, {"file", withoutLamp.filename().string()}}}},
                     {"lights",
                      {{{"type", "spot"},
                        {"position", {2, 3, 0}},
                        {"direction", {0, -1, 0}},
                        {"intensity", watts / (4.0 * kPi)},
                        {"cone_angle", 0.6 * 180.0 / kPi},
                        {"falloff_start", 0.3 * 180.0 / kPi}}}}};
  Scene radiometric = test::loadSceneJson(dir, twin);
  radiometric.render = gltf.render;
  test::expectSameImage(test::renderStatistics(gltf, 16), test::renderStatistics(radiometric, 16));
}

// ---- glass ------------------------------------------------------------------------------------

// A UV sphere: positions and outward-wound triangles.
struct Sphere {
  std::vector<float> positions;
  std::vector<uint16_t> indices;
  Sphere(DVec3 centre, double radius, int rings = 24, int segments = 48) {
    for (int r = 0; r <= rings; ++r)
      for (int k = 0; k <= segments; ++k) {
        const double theta = kPi * r / rings, phi = 2 * kPi * k / segments;
        const DVec3 p =
            centre + radius * DVec3(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
        positions.insert(positions.end(), {float(p.x), float(p.y), float(p.z)});
      }
    const auto at = [&](int r, int k) { return uint16_t(r * (segments + 1) + k); };
    for (int r = 0; r < rings; ++r)
      for (int k = 0; k < segments; ++k) {
        if (r > 0) indices.insert(indices.end(), {at(r, k), at(r, k + 1), at(r + 1, k)});
        if (r < rings - 1) indices.insert(indices.end(), {at(r, k + 1), at(r + 1, k + 1), at(r + 1, k)});
      }
  }
  int addTo(Builder& b, int material) const {
    json primitive = {{"attributes", {{"POSITION", b.floats(positions, "VEC3")}}},
                      {"indices", b.indices(indices)},
                      {"material", material}};
    if (!b.doc.contains("meshes")) b.doc["meshes"] = json::array();
    return b.add("meshes", {{"primitives", json::array({primitive})}});
  }
  json asTriangles(const std::string& material) const {
    json vertices = json::array(), triangles = json::array();
    for (size_t i = 0; i < positions.size(); i += 3)
      vertices.push_back({positions[i], positions[i + 1], positions[i + 2]});
    for (size_t i = 0; i < indices.size(); i += 3) triangles.push_back({indices[i], indices[i + 1], indices[i + 2]});
    return {{"type", "triangles"}, {"material", material}, {"vertices", vertices}, {"indices", triangles}};
  }
};

// A glass ball on a two-coloured floor under a quad light, as glTF with `glass` as material 2,
// and its JSON twin with `glassJson`.
struct GlassScene {
  Sphere ball{DVec3(0, 0.5, 0), 0.5};
  std::vector<Quad> red{{DVec3(-2, 0, -2), DVec3(0, 0, 4), DVec3(2, 0, 0)}},
      blue{{DVec3(0, 0, -2), DVec3(0, 0, 4), DVec3(2, 0, 0)}};
  Quad light{DVec3(-0.5, 2.5, -0.5), DVec3(1, 0, 0), DVec3(0, 0, 1)};

  Scene gltf(const test::TempDir& dir, const json& glass, const std::string& name) const {
    Builder b;
    b.doc["extensionsUsed"] = {"KHR_materials_specular", "KHR_materials_emissive_strength",
                               "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"};
    b.doc["materials"] = {lambertianGltf("red", DVec3(0.7, 0.1, 0.1)),
                          lambertianGltf("blue", DVec3(0.1, 0.1, 0.7)),
                          glass,
                          {{"name", "light"},
                           {"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 0, 1}}, {"metallicFactor", 0.0}}},
                           {"emissiveFactor", {1, 1, 1}},
                           {"extensions",
                            {{"KHR_materials_emissive_strength", {{"emissiveStrength", 8.0}}},
                             {"KHR_materials_specular", {{"specularFactor", 0.0}}}}}}};
    addQuads(b, red, 0);
    addQuads(b, blue, 1);
    ball.addTo(b, 2);
    addQuads(b, {light}, 3);
    b.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.7}, {"znear", 0.1}}}}};
    b.doc["nodes"] = {
        {{"mesh", 0}},
        {{"mesh", 1}},
        {{"mesh", 2}},
        {{"mesh", 3}},
        {{"camera", 0}, {"translation", {0, 1.2, 3}}, {"rotation", {-std::sin(0.12), 0, 0, std::cos(0.12)}}}};
    return loadModel(dir, b, name, 40, 40, 16, 8);
  }

  Scene twin(const test::TempDir& dir, const json& glassJson) const {
    json j = {{"format", "lensfarm-scene/1"},
              {"render", {{"resolution", {40, 40}}, {"samples_per_pixel", 16}, {"max_bounces", 8}}},
              {"camera",
               {{"type", "pinhole"},
                {"position", {0, 1.2, 3}},
                {"look_at", {0, 1.2 - std::sin(0.24), 3 - std::cos(0.24)}},
                {"angle_of_view", 0.7 * 180 / kPi},
                {"fov_axis", "vertical"}}},
              {"materials",
               {{"red", {{"type", "lambertian"}, {"albedo", {0.7, 0.1, 0.1}}}},
                {"blue", {{"type", "lambertian"}, {"albedo", {0.1, 0.1, 0.7}}}},
                {"glass", glassJson}}},
              {"shapes", json::array({ball.asTriangles("glass")})},
              {"lights",
               {{{"type", "quad"},
                 {"corner", vec(light.corner)},
                 {"edge1", vec(light.e1)},
                 {"edge2", vec(light.e2)},
                 {"radiance", 8}}}}};
    for (const json& q : jsonQuads(red, "red")) j["shapes"].push_back(q);
    for (const json& q : jsonQuads(blue, "blue")) j["shapes"].push_back(q);
    return test::loadSceneJson(dir, j, "twin.json");
  }
};

json gltfGlass(double roughness, bool volume) {
  json g = {{"name", "glass"},
            {"pbrMetallicRoughness",
             {{"baseColorFactor", {1, 1, 1, 1}}, {"metallicFactor", 0.0}, {"roughnessFactor", roughness}}},
            {"extensions",
             {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}}, {"KHR_materials_ior", {{"ior", 1.5}}}}}};
  // thicknessFactor: the ball's diameter, as Blender writes a solid's.
  if (volume) g["extensions"]["KHR_materials_volume"] = {{"thicknessFactor", 1.0}};
  return g;
}

TEST(OtherTools, SolidGltfGlassRefractsAsTheDielectric) {
  // KHR_materials_transmission + KHR_materials_ior + KHR_materials_volume (thicknessFactor > 0):
  // the surface bounds a solid of index 1.5, which refracts: the same image as the dielectric
  // material's ball, smooth and rough.
  const GlassScene scene;
  const test::TempDir dir;
  for (const double roughness : {0.0, 0.3}) {
    const Scene solid = scene.gltf(dir, gltfGlass(roughness, true), "solid.gltf");
    const Scene dielectric = scene.twin(dir, {{"type", "dielectric"}, {"ior", 1.5}, {"roughness", roughness}});
    SCOPED_TRACE("roughness " + std::to_string(roughness));
    test::expectSameImage(test::renderStatistics(solid, 16), test::renderStatistics(dielectric, 16));
  }
}

TEST(OtherTools, ThinGltfGlassDoesNotRefract) {
  // Without KHR_materials_volume the same material is thin-walled: light passes without bending,
  // so the ball is not the solid's image (most pixels through the ball differ).
  const GlassScene scene;
  const test::TempDir dir;
  const test::ImageStatistics thin = test::renderStatistics(scene.gltf(dir, gltfGlass(0.0, false), "thin.gltf"), 8);
  const test::ImageStatistics solid =
      test::renderStatistics(scene.twin(dir, {{"type", "dielectric"}, {"ior", 1.5}}), 8);
  EXPECT_LT(test::agreementFraction(thin, solid), 0.97);
}

}  // namespace
}  // namespace lensfarm
