#include "common/math/distribution.h"

#include <algorithm>
#include <cfloat>
#include <stdexcept>
#include <string>

namespace lensfarm {
namespace {

// The largest float below 1: where u is clamped, and the upper end of every returned sample.
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// A weight as the distribution counts it: negative and NaN are 0, above the largest float (and
// +inf) is the largest float. Sums of up to 2^24 such weights stay finite in double.
double sanitize(double w) {
  if (!(w > 0.0)) return 0.0;
  return std::min(w, double(FLT_MAX));
}

// cdf[i] = (w_0 + ... + w_{i-1}) / W, accumulated in double: the integral of the step function
// up to i/n over its total (the cells' common width 1/n cancels). cdf[n] is set to exactly 1; cells after the last
// positive weight also get exactly 1 (sum / sum), so a u below 1 never reaches them. All zero: cdf[i] = i / n.
template <class T>
void buildCdf(std::span<const T> weights, std::vector<double>& cdf, double& integral, bool& uniformFallback) {
  const size_t n = std::max<size_t>(weights.size(), 1);
  cdf.assign(n + 1, 0.0);
  double sum = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) {
    sum += sanitize(double(weights[i]));
    cdf[i + 1] = sum;
  }
  integral = sum / double(n);
  uniformFallback = !(sum > 0.0);
  for (size_t i = 1; i < n; ++i) cdf[i] = uniformFallback ? double(i) / double(n) : cdf[i] / sum;
  cdf[n] = 1.0;
}

double clampU(float u) { return u >= 0.0f ? double(std::min(u, kOneMinusEpsilon)) : 0.0; }  // NaN -> 0

}  // namespace

Distribution1D::Distribution1D(std::span<const float> weights) : n_(std::max(int(weights.size()), 1)) {
  buildCdf(weights, cdf_, integral_, uniformFallback_);
}

Distribution1D::Distribution1D(std::span<const double> weights) : n_(std::max(int(weights.size()), 1)) {
  buildCdf(weights, cdf_, integral_, uniformFallback_);
}

// The cell o with cdf[o] <= u < cdf[o+1], for u in [0,1). Such a cell has positive width, so
// a positive weight: cells of zero weight have cdf[o] == cdf[o+1] and hold no u.
int Distribution1D::findCell(double u) const {
  const auto it = std::upper_bound(cdf_.begin() + 1, cdf_.end(), u);  // the first cdf[k] > u, k >= 1
  return std::clamp(int(it - cdf_.begin()) - 1, 0, n_ - 1);
}

float Distribution1D::sample(float u, float* pdf, int* offset) const {
  const double uc = clampU(u);
  const int o = findCell(uc);
  const double lo = cdf_[o], width = cdf_[o + 1] - lo;
  // Linear inversion inside the cell: x = (o + (u - cdf[o]) / (cdf[o+1] - cdf[o])) / n.
  float x = float((double(o) + (uc - lo) / width) / double(n_));
  // Rounding to float may carry x across the cell's edge (to the next cell, or to 1 from the
  // last): step it back one float at a time. Every cell holds a float (n <= 2^24).
  while (std::floor(double(x) * double(n_)) > double(o)) x = std::nextafter(x, 0.0f);
  while (std::floor(double(x) * double(n_)) < double(o)) x = std::nextafter(x, 1.0f);
  if (pdf) *pdf = float(width * double(n_));
  if (offset) *offset = o;
  return x;
}

int Distribution1D::sampleDiscrete(float u, float* pmf, float* uRemapped) const {
  const double uc = clampU(u);
  const int o = findCell(uc);
  const double lo = cdf_[o], width = cdf_[o + 1] - lo;
  if (pmf) *pmf = float(width);
  if (uRemapped) *uRemapped = std::min(float((uc - lo) / width), kOneMinusEpsilon);
  return o;
}

float Distribution1D::pdf(float x) const {
  if (!(x >= 0.0f && x <= 1.0f)) return 0.0f;
  const int o = cellIndex(x, n_);
  return float((cdf_[o + 1] - cdf_[o]) * double(n_));
}

float Distribution1D::pmf(int i) const {
  if (i < 0 || i >= n_) return 0.0f;
  return float(cdf_[i + 1] - cdf_[i]);
}

float Distribution1D::invert(float x) const {
  if (!(x > 0.0f)) return 0.0f;
  if (x >= 1.0f) return 1.0f;
  const int o = cellIndex(x, n_);
  const double t = double(x) * double(n_) - double(o);  // position inside the cell, in [0,1)
  return float(cdf_[o] + t * (cdf_[o + 1] - cdf_[o]));
}

namespace {

std::span<const float> checkedGrid(std::span<const float> weights, int nu, int nv) {
  if (nu < 1 || nv < 1 || weights.size() != size_t(nu) * size_t(nv))
    throw std::invalid_argument("Distribution2D: " + std::to_string(weights.size()) + " weights for a " +
                                std::to_string(nu) + " x " + std::to_string(nv) + " grid");
  return weights;
}

std::vector<Distribution1D> rowsOf(std::span<const float> weights, int nu, int nv) {
  std::vector<Distribution1D> rows;
  rows.reserve(size_t(nv));
  for (int v = 0; v < nv; ++v) rows.emplace_back(weights.subspan(size_t(v) * size_t(nu), size_t(nu)));
  return rows;
}

Distribution1D marginalOf(const std::vector<Distribution1D>& rows) {
  std::vector<double> integrals(rows.size());
  for (size_t v = 0; v < rows.size(); ++v) integrals[v] = rows[v].integral();
  return Distribution1D(std::span<const double>(integrals));
}

}  // namespace

// Rows sampled from the marginal p(v) = integral of row v / integral of all, then x from the
// conditional p(u | v) = w(u, v) / integral of row v; p(u, v) = p(v) p(u | v) = w(u, v) / integral.
Distribution2D::Distribution2D(std::span<const float> weights, int nu, int nv)
    : nu_(nu),
      nv_(nv),
      conditional_(rowsOf(checkedGrid(weights, nu, nv), nu, nv)),
      marginal_(marginalOf(conditional_)) {}

Vec2 Distribution2D::sample(Vec2 u, float* pdf, glm::ivec2* cell) const {
  float pdfV = 0.0f, pdfU = 0.0f;
  int row = 0, column = 0;
  const float y = marginal_.sample(u.y, &pdfV, &row);
  const float x = conditional_[size_t(row)].sample(u.x, &pdfU, &column);
  if (pdf) *pdf = pdfU * pdfV;
  if (cell) *cell = glm::ivec2(column, row);
  return Vec2(x, y);
}

float Distribution2D::pdf(Vec2 uv) const {
  if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f)) return 0.0f;
  const int row = cellIndex(uv.y, nv_);
  return conditional_[size_t(row)].pdf(uv.x) * marginal_.pdf(uv.y);
}

}  // namespace lensfarm
