// The memory estimate (farm/memory_estimate.h) against what the buffers really take: the
// types' allocations and the allocator's own count.
#include <gtest/gtest.h>
#include <malloc.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "common/farm/memory_estimate.h"
#include "common/film/convergence.h"
#include "common/film/image.h"
#include "common/film/sensor.h"
#include "common/light/environment_light.h"
#include "common/medium/medium.h"
#include "tests/film/memory_estimate_support.h"

namespace lensfarm {
namespace {

using test::settingsOf;

uint64_t itemBytes(const MemoryEstimate& e, const std::string& prefix) {
  for (const auto& i : e.items)
    if (i.what.rfind(prefix, 0) == 0) return i.bytes;
  ADD_FAILURE() << "no item " << prefix << " in " << e.describe();
  return 0;
}

TEST(MemoryEstimate, TheFormulaIsWhatTheBufferTypesAllocate) {
  const int w = 37, h = 23;
  const uint64_t cells = uint64_t(w) * h;
  Sensor sensor(w, h);
  ConvergenceTracker tracker(w, h);
  SensorBuffer unit(w, h);
  EXPECT_EQ(sensor.memoryBytes(), cells * kSensorBytesPerCell);
  EXPECT_EQ(tracker.memoryBytes(), cells * kTrackerBytesPerCell);
  EXPECT_EQ(unit.memoryBytes(), cells * kUnitBufferBytesPerCell);
  EXPECT_EQ(sensor.developImage().rgb.size() * sizeof(float), cells * kImageBytesPerCell);
  EXPECT_EQ(kSensorBytesPerCell, 48u);
  EXPECT_EQ(kTrackerBytesPerCell, 24u);
  EXPECT_EQ(kUnitBufferBytesPerCell, 28u);

  // Units add no per-cell sample counts to the sensor: they cover the whole frame.
  std::fill(unit.samples.begin(), unit.samples.end(), 4u);
  std::fill(unit.sums.begin(), unit.sums.end(), 1.0);
  for (int k = 0; k < 3; ++k) sensor.add(unit);
  sensor.add(unit, 4);
  EXPECT_EQ(sensor.memoryBytes(), cells * kSensorBytesPerCell);
  EXPECT_EQ(sensor.totalSamples(), cells * 16);
  EXPECT_EQ(sensor.samples(3, 5), 16u);
  EXPECT_EQ(sensor.serialize().size(), 8 + 16 + cells * (kCheckpointBytesPerCell - kTrackerBytesPerCell));
  EXPECT_EQ(tracker.serialize().size(), 32 + cells * kTrackerBytesPerCell);

  // The estimates are those per-cell sizes times the frame.
  const RenderSettings s = settingsOf(w, h);
  const MemoryEstimate coordinator = coordinatorJobMemory(s, uint64_t(2) << 30, true);
  EXPECT_EQ(itemBytes(coordinator, "sensor"), sensor.memoryBytes());
  EXPECT_EQ(itemBytes(coordinator, "error-estimate"), tracker.memoryBytes());
  EXPECT_EQ(itemBytes(coordinator, "1 unit buffer"), unit.memoryBytes()) << "a 1-spp job has one unit";
  EXPECT_EQ(itemBytes(coordinator, "a checkpoint"),
            sensor.serialize().size() + tracker.serialize().size() - 8 - 16 - 32);
  const MemoryEstimate local = localRenderMemory(s, 0);
  EXPECT_EQ(local.total(), sensor.memoryBytes() + tracker.memoryBytes() + unit.memoryBytes() +
                               cells * (kImageBytesPerCell + kPngBytesPerCell));
  EXPECT_EQ(itemBytes(coordinator, "a download"), cells * (kImageBytesPerCell + kPngBytesPerCell));
  EXPECT_EQ(imageMemory(s), itemBytes(coordinator, "a download"));
  // The audit's film copies (a sensor and a tracker each) and one audited unit's sums.
  EXPECT_EQ(itemBytes(coordinatorJobMemory(s, uint64_t(2) << 30, true, 3), "3 film copies"),
            3 * (sensor.memoryBytes() + tracker.memoryBytes()) + unit.memoryBytes());
  EXPECT_EQ(coordinatorJobMemory(s, uint64_t(2) << 30, true, 0).total(), coordinator.total()) << "no audit, no copies";
}

TEST(MemoryEstimate, TheAllocatorCountsWhatTheFormulaSays) {
  // The allocator's own count of bytes in use, before and while a sensor and tracker live.
  const int w = 640, h = 480;
  const uint64_t cells = uint64_t(w) * h;
  const auto inUse = [] {
    const struct mallinfo2 m = mallinfo2();
    return uint64_t(m.uordblks) + uint64_t(m.hblkhd);
  };
  const uint64_t before = inUse();
  auto sensor = std::make_unique<Sensor>(w, h);
  auto tracker = std::make_unique<ConvergenceTracker>(w, h);
  const uint64_t measured = inUse() - before;
  const uint64_t formula = cells * (kSensorBytesPerCell + kTrackerBytesPerCell);
  EXPECT_GE(measured, formula);
  // Each of the two blocks may be rounded up to 2 MiB and aligned at 2 MiB (util/large_pages.h),
  // which the allocator counts: at most 4 MiB each, of which at most 2 MiB is ever written.
  const uint64_t largePageSlack = 2 * (uint64_t(4) << 20);
  EXPECT_LE(measured, formula + 16 * 1024 + largePageSlack)
      << "allocated " << measured << " bytes, the formula says " << formula;
}

TEST(MemoryEstimate, HugeFramesAreEstimatedBeforeAnythingIsAllocated) {
  const RenderSettings huge = settingsOf(16384, 16384);
  const uint64_t cells = uint64_t(16384) * 16384;
  const MemoryEstimate local = localRenderMemory(huge, 30);
  EXPECT_EQ(local.total(), cells * (48 + 24 + 28 + 12 + 6) + 30 * kSceneBytesPerTriangle);
  EXPECT_GT(local.total(), uint64_t(29) << 30);
  // Many units: the coordinator may hold a window of them ahead of the summed prefix.
  const RenderSettings many = settingsOf(16384, 16384, 64);
  EXPECT_EQ(unitsAheadWindow(16384, 16384, uint64_t(2) << 30), 8u);
  EXPECT_EQ(itemBytes(coordinatorJobMemory(many, uint64_t(2) << 30, false), "8 unit buffers"), 8 * cells * 28);
  const std::string text = local.describe();
  EXPECT_NE(text.find("sensor 12.9 GB"), std::string::npos) << text;
  const std::string refusal = overBudgetMessage(huge, local, "", uint64_t(16) << 30, "--max-job-memory");
  EXPECT_NE(refusal.find("16384x16384"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("an estimated 31.7 GB"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("17.2 GB allowed"), std::string::npos) << refusal;
}

// This machine's memory read independently of the code under test: MemTotal of /proc/meminfo, and
// the memory.max (cgroup v2) of this process's cgroup and of every cgroup above it, the lowest wins.
uint64_t memoryThisMachineAllows() {
  uint64_t limit = 0;
  std::ifstream meminfo("/proc/meminfo");
  for (std::string key; meminfo >> key;) {
    uint64_t kib = 0;
    meminfo >> kib;
    if (key == "MemTotal:") limit = kib * 1024;
    meminfo.ignore(1 << 10, '\n');
  }
  std::ifstream self("/proc/self/cgroup");
  for (std::string line; std::getline(self, line);) {
    if (line.rfind("0::", 0) != 0) continue;
    for (std::filesystem::path dir = "/sys/fs/cgroup" + line.substr(3);; dir = dir.parent_path()) {
      std::ifstream max(dir / "memory.max");
      uint64_t v = 0;
      if (max >> v && v > 0) limit = std::min(limit, v);
      if (dir == "/sys/fs/cgroup" || dir == dir.parent_path()) break;
    }
  }
  return limit;
}

// Without LENSFARM_MAX_JOB_MEMORY a job may take 3/4 of what this machine (or its cgroup) has, and
// the messages say so with that figure. (The refusals themselves are tested with a set budget in
// tests/farm/memory_farm_test.cpp: a machine's own memory cannot be made small for a test.)
TEST(MemoryEstimate, TheDefaultBudgetIsThreeQuartersOfWhatThisMachineAllows) {
  const char* set = std::getenv("LENSFARM_MAX_JOB_MEMORY");
  const std::string saved = set ? set : "";
  ::unsetenv("LENSFARM_MAX_JOB_MEMORY");
  const uint64_t allowed = memoryThisMachineAllows();
  ASSERT_GT(allowed, uint64_t(64) << 20);
  EXPECT_NEAR(double(machineMemoryBytes()), double(allowed), 1e-6 * double(allowed));
  EXPECT_NEAR(double(defaultJobMemoryBudget()), 0.75 * double(allowed), 1e-6 * double(allowed));
  EXPECT_EQ(defaultJobMemoryBudgetSource(), "3/4 of this machine's " + formatBytes(allowed) + " of memory");
  ::setenv("LENSFARM_MAX_JOB_MEMORY", "3G", 1);
  EXPECT_EQ(defaultJobMemoryBudget(), uint64_t(3) << 30);
  EXPECT_EQ(defaultJobMemoryBudgetSource(), "LENSFARM_MAX_JOB_MEMORY");
  if (set)
    ::setenv("LENSFARM_MAX_JOB_MEMORY", saved.c_str(), 1);
  else
    ::unsetenv("LENSFARM_MAX_JOB_MEMORY");
}

TEST(MemoryEstimate, SizesParseAndPrint) {
  EXPECT_EQ(parseByteSize("16G"), uint64_t(16) << 30);
  EXPECT_EQ(parseByteSize("512MiB"), uint64_t(512) << 20);
  EXPECT_EQ(parseByteSize("1.5GB"), 1500000000u);
  EXPECT_EQ(parseByteSize("2000000000"), 2000000000u);
  EXPECT_EQ(parseByteSize("64 k"), 65536u);
  for (const char* bad : {"", "0", "-1G", "lots", "12X", "G", "1e30"}) EXPECT_EQ(parseByteSize(bad), 0u) << bad;
  EXPECT_EQ(formatBytes(31700000000), "31.7 GB");
  EXPECT_EQ(formatBytes(829440000), "829 MB");
  EXPECT_EQ(formatBytes(512), "512 bytes");
  EXPECT_GT(machineMemoryBytes(), uint64_t(64) << 20);
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// Textures count once however many materials share them, with every mip level; vertex
// attributes count by their arrays' sizes.
TEST(MemoryEstimate, TexturesAndVertexAttributesCountInTheScene) {
  Scene scene;
  RgbaImage image;
  image.width = image.height = 4;
  image.texels.assign(4 * 16, 0.5f);
  const auto texture = std::make_shared<Texture>("t", image);
  ASSERT_EQ(texture->bytes(), (16 + 4 + 1) * 4 * sizeof(float));  // 4x4, 2x2, 1x1, RGBA floats
  auto textures = std::make_shared<MaterialTextures>();
  textures->baseColor.texture = texture;
  textures->emissive.texture = texture;
  scene.materials.push_back(Material::textured("a", textures));
  scene.materials.push_back(Material::textured("b", textures));
  TriangleMesh mesh;
  mesh.normals.assign(3, Vec3(0, 0, 1));
  mesh.uv[0].assign(3, Vec2(0.0f));
  scene.meshes.push_back(mesh);
  const uint64_t expected = texture->bytes() + 3 * sizeof(Vec3) + 3 * sizeof(Vec2);
  EXPECT_EQ(sceneDataBytes(scene), expected);
  RenderSettings s;
  s.width = s.height = 8;
  EXPECT_EQ(workerJobMemory(s, 1, expected).total(), workerJobMemory(s, 1).total() + expected);
  EXPECT_NE(workerJobMemory(s, 1, expected).describe().find("textures, vertex attributes and instances"),
            std::string::npos);

  // An environment map: 12 bytes of radiance and 8 of sampling distribution a pixel.
  Image sky;
  sky.width = 64, sky.height = 32;
  sky.rgb.assign(size_t(64) * 32 * 3, 0.25f);
  scene.lights.push_back(std::make_shared<EnvironmentLight>(
      "sky.exr", std::make_shared<const EnvironmentMap>(EnvironmentMap::fromImage(sky))));
  EXPECT_EQ(sceneDataBytes(scene), expected + 64 * 32 * (12 + 8));

  // A density grid: 4 bytes a voxel and a majorant cell (16^3), each grid once however many
  // materials use it; a homogeneous medium holds no array.
  auto grid = std::make_shared<Medium>("smoke",
                                       GridMedium(Vec3(0.0f), Vec3(1.0f), glm::ivec3(10, 20, 30),
                                                  std::vector<float>(6000, 1.0f), Spectrum(1.0f), Spectrum(0.0f), 0.0f),
                                       DVec3(0.0), DVec3(1.0));
  scene.media["smoke"] = grid;
  scene.media["haze"] = std::make_shared<Medium>("haze", HomogeneousMedium(Spectrum(0.1f), Spectrum(0.1f), 0.0f));
  EXPECT_EQ(sceneDataBytes(scene), expected + 64 * 32 * (12 + 8) + (6000 + 16 * 16 * 16) * 4);
}

}  // namespace
}  // namespace lensfarm
