// Embree's narrower kernels (LENSFARM_EMBREE_CONFIG="isa=..."), which a worker without AVX-512
// uses: there Embree traces a 16-wide packet through its ray-stream path, which ignores the mask
// of lanes in use and traces (and asserts on) every lane whose tnear <= tfar. Packets with lanes
// not in use, holding anything at all, must still trace only their lanes in use and give the
// one-ray results, and a whole render must give the same bits in packets as one ray at a time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>

#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

// Embree reads LENSFARM_EMBREE_CONFIG when a RayCaster is made.
struct EmbreeConfig : test::ScopedEnv {
  explicit EmbreeConfig(const char* value) : test::ScopedEnv("LENSFARM_EMBREE_CONFIG", value) {}
};

Scene classicScene(test::TempDir& dir, int size, int spp) {
  nlohmann::json scene = test::bundledSceneJson("cornell-classic.json");
  scene["render"]["resolution"] = {size, size};
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = 1;
  return test::loadSceneJson(dir, scene);
}

class NarrowKernels : public ::testing::TestWithParam<const char*> {};

TEST_P(NarrowKernels, PacketLanesNotInUseAreNeverTraced) {
  EmbreeConfig config(GetParam());
  test::TempDir dir;
  const Scene scene = classicScene(dir, 8, 1);
  const RayCaster caster(scene);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Five rays from inside the box in different directions; the other lanes hold NaNs.
  RayPacket rays;
  for (int k = 0; k < kPacketWidth; ++k) {
    rays.valid[k] = 0;
    rays.ox[k] = rays.oy[k] = rays.oz[k] = rays.dx[k] = rays.dy[k] = rays.dz[k] = rays.tFar[k] = nan;
  }
  const Vec3 origin(DVec3(0.1, 0.2, 0.0) - scene.origin);  // a point inside the box, in render space
  const Vec3 directions[5] = {{1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {-1, 0.2f, 0.1f}, {0.3f, -0.2f, 1}};
  for (int k = 0; k < 5; ++k) rays.set(2 * k, origin, glm::normalize(directions[k]), 0.5f);

  RayCaster::PacketHits hits;
  caster.intersect(rays, RayKind::kScattered, hits);
  bool blocked[kPacketWidth];
  caster.occluded(rays, blocked);
  int found = 0;
  for (int k = 0; k < kPacketWidth; ++k) {
    if (!rays.active(k)) {
      EXPECT_EQ(hits.found[k], 0) << "lane " << k << " is not in use";
      EXPECT_FALSE(blocked[k]) << "lane " << k << " is not in use";
      continue;
    }
    const auto single = caster.intersect(rays.origin(k), rays.direction(k), RayKind::kScattered);
    ASSERT_EQ(hits.found[k] != 0, single.has_value()) << "lane " << k;
    if (single) {
      ++found;
      // Every field, bit for bit.
      static_assert(sizeof(SurfaceHit) == 16 * sizeof(float), "SurfaceHit has no padding for memcmp");
      const SurfaceHit lane = hits.hit(k);
      EXPECT_EQ(lane.triangle, single->triangle) << "lane " << k;
      EXPECT_EQ(std::memcmp(&lane, &*single, sizeof(SurfaceHit)), 0) << "lane " << k;
    }
    EXPECT_EQ(blocked[k], caster.occluded(rays.origin(k), rays.direction(k), 0.5f)) << "lane " << k;
  }
  EXPECT_EQ(found, 5) << "every ray from inside the box hits a wall";
}

TEST_P(NarrowKernels, PartialPacketsRenderTheSameBitsAsSingleRays) {
  // 8 x 8 at 1 spp: each row is one packet of 8 lanes, and paths leave it as they end.
  EmbreeConfig config(GetParam());
  test::TempDir dir;
  const Scene scene = classicScene(dir, 8, 4);
  const RenderScene rs(scene);
  for (uint64_t u = 0; u < 4; ++u) {
    const WorkUnit unit = unitAt(u, 4, 1);
    SensorBuffer packets, singles;
    PathStats packetStats, singleStats;
    ASSERT_TRUE(renderUnit(rs, unit, packets, packetStats, nullptr, RayGrouping::kPackets));
    ASSERT_TRUE(renderUnit(rs, unit, singles, singleStats, nullptr, RayGrouping::kSingleRays));
    EXPECT_EQ(std::memcmp(packets.sums.data(), singles.sums.data(), packets.sums.size() * sizeof(double)), 0);
    EXPECT_EQ(packetStats.rays, singleStats.rays);
    double total = 0.0;
    for (double v : packets.sums) total += v;
    EXPECT_GT(total, 0.0);
  }
}

// SSE2 and AVX2: Embree's 4- and 8-wide kernels, which take the ray-stream path for 16-wide calls.
INSTANTIATE_TEST_SUITE_P(EmbreeIsa, NarrowKernels, ::testing::Values("isa=sse2", "isa=avx2"));

}  // namespace
}  // namespace lensfarm
