// OpenVDB grids as media (medium/vdb_grid.h): a file written the way exporters write it
// (openvdb::io::File, a float grid "density" with a scale-and-translate transform) loads as the
// dense grid whose box and voxel values it holds, renders the same bits as that grid given
// inline, and every file that does not load is refused with one error naming the field.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include "common/medium/medium.h"
#include "common/medium/vdb_grid.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A 3 x 2 x 2 block of active voxels at index (4..6, -1..0, 2..3), voxel size 0.5, translated by
// (1, 2, 3): voxel (i, j, k)'s centre is at (1 + 0.5 i, 2 + 0.5 j, 3 + 0.5 k). Value 1 + i + 10 j
// + 100 k ... offset to stay positive.
void writeVdb(const std::filesystem::path& path, const std::string& gridName = "density", bool vectorGrid = false) {
  openvdb::initialize();
  openvdb::GridPtrVec grids;
  openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(0.5);
  xf->postTranslate(openvdb::Vec3d(1, 2, 3));
  if (vectorGrid) {
    openvdb::Vec3SGrid::Ptr g = openvdb::Vec3SGrid::create();
    g->setName(gridName);
    g->tree().setValue(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 2, 3));
    grids.push_back(g);
  } else {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->setName(gridName);
    g->setTransform(xf);
    for (int k = 2; k <= 3; ++k)
      for (int j = -1; j <= 0; ++j)
        for (int i = 4; i <= 6; ++i)
          g->tree().setValue(openvdb::Coord(i, j, k), float(1 + (i - 4) + 10 * (j + 1) + 100 * (k - 2)));
    grids.push_back(g);
  }
  openvdb::io::File file(path.string());
  file.write(grids);
  file.close();
}

TEST(VdbGrid, AFileFromOpenVdbLoadsAsTheDenseGridOfItsActiveVoxels) {
  test::TempDir dir;
  writeVdb(dir.path() / "smoke.vdb");
  const std::string bytes = test::readFile(dir.path() / "smoke.vdb");
  const DenseGrid g = readVdbGrid(bytes, "density", "smoke.vdb", "scene.json", "media.smoke.file");
  EXPECT_EQ(g.resolution, glm::ivec3(3, 2, 2));
  // Index 4 - 0.5 .. 6 + 0.5 times 0.5 plus 1; -1.5 .. 0.5 times 0.5 plus 2; 1.5 .. 3.5 times 0.5 plus 3.
  EXPECT_EQ(g.lo, DVec3(2.75, 1.25, 3.75));
  EXPECT_EQ(g.hi, DVec3(4.25, 2.25, 4.75));
  ASSERT_EQ(g.density.size(), 12u);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 3; ++i) EXPECT_EQ(g.density[size_t((k * 2 + j) * 3 + i)], float(1 + i + 10 * j + 100 * k));
}

TEST(VdbGrid, RendersTheSameBitsAsTheSameGridInline) {
  test::TempDir dir;
  writeVdb(dir.path() / "smoke.vdb");
  const DenseGrid g = readVdbGrid(test::readFile(dir.path() / "smoke.vdb"), "density", "smoke.vdb", "s", "f");
  json scene = test::minimalSceneJson();
  scene["camera"] = {{"type", "pinhole"}, {"position", {3.5, 1.75, -3}}, {"look_at", {3.5, 1.75, 4}},
                     {"up", {0, 1, 0}},   {"sensor_width", 0.1},         {"focal_length", 0.1}};
  scene["environment"] = {{"radiance", 1.0}};
  scene["medium"] = "smoke";
  json inlineGrid = {{"type", "grid"},          {"bounds", {{g.lo.x, g.lo.y, g.lo.z}, {g.hi.x, g.hi.y, g.hi.z}}},
                     {"resolution", {3, 2, 2}}, {"density", g.density},
                     {"sigma_s", 0.02},         {"sigma_a", 0.01}};
  scene["media"] = {{"smoke", inlineGrid}};
  const test::Rendered a = test::renderScene(test::loadSceneJson(dir, scene));
  scene["media"]["smoke"] = {{"type", "grid"}, {"file", "smoke.vdb"}, {"sigma_s", 0.02}, {"sigma_a", 0.01}};
  const Scene fromFile = test::loadSceneJson(dir, scene);
  EXPECT_EQ(fromFile.assets.count("smoke.vdb"), 1u) << "the file is an asset the farm ships";
  const test::Rendered b = test::renderScene(fromFile);
  ASSERT_EQ(a.image.rgb.size(), b.image.rgb.size());
  EXPECT_EQ(0, std::memcmp(a.image.rgb.data(), b.image.rgb.data(), a.image.rgb.size() * sizeof(float)));
  // The smoke is in the picture: the sky (radiance 1) behind it is dimmed.
  EXPECT_LT(*std::min_element(a.image.rgb.begin(), a.image.rgb.end()), 0.9f);
}

void expectError(const test::TempDir& dir, const json& medium, const std::string& part) {
  json scene = test::minimalSceneJson();
  scene["media"] = {{"smoke", medium}};
  scene["medium"] = "smoke";
  try {
    test::loadSceneJson(dir, scene);
    ADD_FAILURE() << "no error; expected " << part;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(VdbGrid, AFileThatDoesNotLoadIsOneClearError) {
  test::TempDir dir;
  writeVdb(dir.path() / "smoke.vdb");
  writeVdb(dir.path() / "velocity.vdb", "vel", true);
  {
    std::ofstream(dir.path() / "noise.vdb") << "this is not a VDB file at all";
    const std::string whole = test::readFile(dir.path() / "smoke.vdb");
    std::ofstream(dir.path() / "cut.vdb", std::ios::binary) << whole.substr(0, whole.size() / 2);
  }
  const json base = {{"type", "grid"}, {"sigma_s", 1.0}};
  const auto with = [&](const std::string& file, const std::string& grid = "") {
    json m = base;
    m["file"] = file;
    if (!grid.empty()) m["grid"] = grid;
    return m;
  };
  expectError(dir, with("missing.vdb"), "media.smoke.file: cannot read OpenVDB file");
  expectError(dir, with("noise.vdb"), "media.smoke.file: cannot read");
  expectError(dir, with("cut.vdb"), "media.smoke.file: ");
  expectError(dir, with("smoke.vdb", "temperature"), "has no grid \"temperature\" (it has \"density\")");
  expectError(dir, with("velocity.vdb", "vel"), "holds vec3s, not float densities");
  json both = with("smoke.vdb");
  both["resolution"] = {1, 1, 1};
  expectError(dir, both, "media.smoke.resolution: comes from the file");
}

}  // namespace
}  // namespace lensfarm
