#include "common/medium/grid_medium.h"

#include <algorithm>
#include <cmath>

#include "common/medium/homogeneous_medium.h"
#include "common/util/error.h"

namespace lensfarm {

GridMedium::GridMedium(const Vec3& lo, const Vec3& hi, const glm::ivec3& resolution, std::vector<float> density,
                       const Spectrum& sigmaA, const Spectrum& sigmaS, float g, const glm::ivec3& majorantResolution)
    : lo_(lo),
      hi_(hi),
      res_(resolution),
      density_(std::move(density)),
      sigmaA_(sigmaA),
      sigmaS_(sigmaS),
      sigmaT_(sigmaA + sigmaS),
      maxSigmaT_(std::max(sigmaT_.r, std::max(sigmaT_.g, sigmaT_.b))),
      phase_(g),
      majorantRes_(glm::max(majorantResolution, glm::ivec3(1))),
      majorant_(size_t(majorantRes_.x) * size_t(majorantRes_.y) * size_t(majorantRes_.z), 0.0f) {
  // Majorant cell i covers [i / m, (i + 1) / m] of the box on its axis, i.e. voxel coordinates
  // x = p n - 1/2 (centres at integers) in [i n / m - 1/2, (i + 1) n / m - 1/2]; the trilinear
  // values there come from voxels floor(start) to floor(end) + 1, clamped to the grid.
  const auto voxelRange = [&](int a, int i, int* first, int* last) {
    const double n = res_[a], m = majorantRes_[a];
    *first = std::clamp(int(std::floor(i * n / m - 0.5)), 0, res_[a] - 1);
    *last = std::clamp(int(std::floor((i + 1) * n / m - 0.5)) + 1, 0, res_[a] - 1);
  };
  for (int k = 0; k < majorantRes_.z; ++k)
    for (int j = 0; j < majorantRes_.y; ++j)
      for (int i = 0; i < majorantRes_.x; ++i) {
        int x0, x1, y0, y1, z0, z1;
        voxelRange(0, i, &x0, &x1);
        voxelRange(1, j, &y0, &y1);
        voxelRange(2, k, &z0, &z1);
        float m = 0.0f;
        for (int z = z0; z <= z1; ++z)
          for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) m = std::max(m, voxel(x, y, z));
        majorant_[size_t(index(glm::ivec3(i, j, k), majorantRes_))] = m;
      }
}

float GridMedium::density(const Vec3& p) const {
  const Vec3 u = (p - lo_) / (hi_ - lo_);
  if (!(u.x >= 0.0f && u.x <= 1.0f && u.y >= 0.0f && u.y <= 1.0f && u.z >= 0.0f && u.z <= 1.0f)) return 0.0f;
  // Voxel coordinates with centres at integers; the 8 neighbours, clamped to the grid.
  const Vec3 v = u * Vec3(res_) - Vec3(0.5f);
  const Vec3 fl = glm::floor(v);
  const Vec3 f = v - fl;
  const glm::ivec3 i0 = glm::clamp(glm::ivec3(fl), glm::ivec3(0), res_ - 1);
  const glm::ivec3 i1 = glm::clamp(glm::ivec3(fl) + 1, glm::ivec3(0), res_ - 1);
  const auto lerp = [](float a, float b, float t) { return (1.0f - t) * a + t * b; };
  const float c00 = lerp(voxel(i0.x, i0.y, i0.z), voxel(i1.x, i0.y, i0.z), f.x);
  const float c10 = lerp(voxel(i0.x, i1.y, i0.z), voxel(i1.x, i1.y, i0.z), f.x);
  const float c01 = lerp(voxel(i0.x, i0.y, i1.z), voxel(i1.x, i0.y, i1.z), f.x);
  const float c11 = lerp(voxel(i0.x, i1.y, i1.z), voxel(i1.x, i1.y, i1.z), f.x);
  return lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z);
}

void validateGridMedium(const Vec3& lo, const Vec3& hi, const glm::ivec3& resolution, const std::vector<float>& density,
                        const Spectrum& sigmaA, const Spectrum& sigmaS, float g, const std::string& where,
                        const std::string& field) {
  if (resolution.x < 1 || resolution.y < 1 || resolution.z < 1)
    throw InputError(where, field + ".resolution: each of nx, ny, nz must be >= 1, got [" +
                                std::to_string(resolution.x) + ", " + std::to_string(resolution.y) + ", " +
                                std::to_string(resolution.z) + "]");
  const size_t expected = size_t(resolution.x) * size_t(resolution.y) * size_t(resolution.z);
  if (density.size() != expected)
    throw InputError(where, field + ".density: holds " + std::to_string(density.size()) + " values, the resolution " +
                                "needs nx ny nz = " + std::to_string(expected));
  for (size_t i = 0; i < density.size(); ++i)
    if (!std::isfinite(density[i]) || density[i] < 0.0f)
      throw InputError(where, field + ".density[" + std::to_string(i) + "]: must be finite and >= 0, got " +
                                  std::to_string(density[i]));
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || !(hi[a] > lo[a]))
      throw InputError(where, field + ".bounds: the box needs finite lo < hi on every axis");
  validateHomogeneousMedium(sigmaA, sigmaS, g, where, field);
  // The densest voxel times the coefficients must stay a valid coefficient too.
  const float densest = density.empty() ? 0.0f : *std::max_element(density.begin(), density.end());
  const float largest = std::max({sigmaA.r, sigmaA.g, sigmaA.b}) + std::max({sigmaS.r, sigmaS.g, sigmaS.b});
  if (double(densest) * double(largest) > double(kMaxCoefficient))
    throw InputError(where, field + ".density: the densest voxel (" + std::to_string(densest) +
                                ") times sigma_a + sigma_s exceeds 1e30 / scene unit");
}

}  // namespace lensfarm
