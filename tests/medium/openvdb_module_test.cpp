// OpenVDB is loaded only for a scene that names a .vdb (medium/vdb_grid.h): none of the three
// binaries needs libopenvdb to start, and `lensfarm render` of a scene with a VDB medium, whose
// reader it loads from its module, gives the same image as the same grid given inline.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <fstream>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

TEST(OpenVdbModule, NoBinaryLoadsOpenVdbToStart) {
  for (const std::filesystem::path& binary : {test::cliPath(), test::coordinatorPath(), test::workerPath()}) {
    // The dynamic linker names every object it loads (LD_DEBUG=files, on stderr).
    const test::ProcessResult run =
        test::runProcess({"/usr/bin/env", "LD_DEBUG=files", binary.string(), "--version"}, 60);
    ASSERT_EQ(run.exitCode, 0) << run.err;
    EXPECT_NE(run.err.find("libstdc++"), std::string::npos) << binary << ": the loader lists what it loads\n"
                                                            << run.err;
    EXPECT_EQ(run.err.find("libopenvdb"), std::string::npos) << binary << " loads OpenVDB to start";
  }
}

TEST(OpenVdbModule, TheCliRendersAVdbMediumAsTheSameGridInline) {
  test::TempDir dir;
  // A 4 x 3 x 2 block of density 0.5 ... 2.8, voxel size 0.25, its box from (-0.5, -0.375, -1.75).
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(0.25);
  xf->postTranslate(openvdb::Vec3d(-0.375, -0.25, -1.625));  // between the camera and the wall
  grid->setTransform(xf);
  std::vector<float> dense;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        dense.push_back(0.5f + 0.1f * float(i + 4 * j + 12 * k));
        grid->tree().setValue(openvdb::Coord(i, j, k), dense.back());
      }
  openvdb::io::File file((dir.path() / "smoke.vdb").string());
  file.write({grid});
  file.close();

  json scene = test::minimalSceneJson();
  scene["environment"] = {{"radiance", 1.0}};
  scene["medium"] = "smoke";
  scene["media"] = {{"smoke", {{"type", "grid"}, {"file", "smoke.vdb"}, {"sigma_s", 2.0}, {"sigma_a", 0.5}}}};
  std::ofstream(dir.path() / "vdb.json") << scene.dump();
  // Voxel (i, j, k)'s centre at (-0.375 + 0.25 i, ...): the box is its voxels grown by half a voxel.
  scene["media"]["smoke"] = {{"type", "grid"},          {"bounds", {{-0.5, -0.375, -1.75}, {0.5, 0.375, -1.25}}},
                             {"resolution", {4, 3, 2}}, {"density", dense},
                             {"sigma_s", 2.0},          {"sigma_a", 0.5}};
  std::ofstream(dir.path() / "inline.json") << scene.dump();

  for (const std::string name : {"vdb", "inline"}) {
    const test::ProcessResult r =
        test::runProcess({test::cliPath().string(), "render", (dir.path() / (name + ".json")).string(), "--resolution",
                          "32x24", "--spp", "8", "-q", "-o", (dir.path() / (name + ".exr")).string()},
                         120);
    ASSERT_EQ(r.exitCode, 0) << name << ": " << r.err;
  }
  const Image fromFile = readExr(dir.path() / "vdb.exr"), given = readExr(dir.path() / "inline.exr");
  EXPECT_EQ(fromFile.rgb, given.rgb) << "the module's grid must be the inline grid, to the bit";
  double sum = 0.0;
  for (float v : given.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
}

}  // namespace
}  // namespace lensfarm
