#include "camera/pupil_mask.h"

#include <cmath>

namespace lensfarm {

std::vector<double> rasterizePupil(int n, int blades, double rotation) {
  constexpr int kSub = 4;
  const double pi = std::acos(-1.0);
  // A regular n-gon inscribed in the unit circle is the intersection of n half-planes
  // x cos(phi_k) + y sin(phi_k) <= cos(pi / n), phi_k the direction of edge k's midpoint.
  std::vector<double> cosPhi, sinPhi;
  for (int k = 0; k < blades; ++k) {
    const double phi = rotation + pi * (2 * k + 1) / blades;
    cosPhi.push_back(std::cos(phi));
    sinPhi.push_back(std::sin(phi));
  }
  const double apothem = blades > 0 ? std::cos(pi / blades) : 1.0;
  const auto inside = [&](double x, double y) {
    if (blades == 0) return x * x + y * y <= 1.0;
    for (int k = 0; k < blades; ++k)
      if (x * cosPhi[k] + y * sinPhi[k] > apothem) return false;
    return true;
  };
  std::vector<double> mask(size_t(n) * n, 0.0);
  const double cell = 2.0 / n;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      int hits = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx)
          hits += inside(-1.0 + cell * (c + (sx + 0.5) / kSub), -1.0 + cell * (r + (sy + 0.5) / kSub));
      mask[size_t(r) * n + c] = double(hits) / (kSub * kSub);
    }
  return mask;
}

}  // namespace lensfarm
