#include "common/camera/depth_of_field.h"

#include <cmath>
#include <limits>

namespace lensfarm {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

double hyperfocalDistance(double f, double n, double c) { return f * f / (n * c) + f; }

// S1 X / denominator, infinite where the far limit has run off to (or past) infinity.
double farLimitOrInfinity(double numerator, double denominator) {
  return denominator > 0.0 ? numerator / denominator : kInf;
}
}  // namespace

double circleOfConfusion(double sensorWidth, double sensorHeight) {
  return std::hypot(sensorWidth, sensorHeight) / 1500.0;
}

DepthOfField seedDepthOfField(double f, double s1, double n, double c) {
  const double h = hyperfocalDistance(f, n, c);
  return DepthOfField{n, h, s1 * h / (h + s1 - f), farLimitOrInfinity(s1 * h, h - s1 - f)};
}

DepthOfField textbookDepthOfField(double f, double s1, double n, double c) {
  const double h = hyperfocalDistance(f, n, c);
  return DepthOfField{n, h, s1 * (h - f) / (h + s1 - 2.0 * f), farLimitOrInfinity(s1 * (h - f), h - s1)};
}

}  // namespace lensfarm
