#pragma once
// Piecewise-constant distributions on [0,1) and [0,1)^2, for sampling in proportion to tabulated
// weights (an environment map's pixels, a light's power). The method is pbrt-v4's
// PiecewiseConstant1D / PiecewiseConstant2D (Pharr, Jakob, Humphreys, "Physically Based
// Rendering", 4th ed., Appendix A: "Sampling 1D Functions" and "Sampling Multidimensional
// Functions"; the derivation is 3rd ed. §13.3.1 and §13.6.7), written afresh here with these
// differences:
//
//  - The cdf is accumulated and stored in double. With n cells of weights w_i and
//    W = sum_i w_i, cdf[i] = (w_0 + ... + w_{i-1}) / W; a float running sum stops growing once
//    it reaches 2^24 times a cell's weight (a 4096 x 2048 map has 2^23 cells), leaving later cells
//    with no width, never sampled although their weight is positive.
//  - Densities are the sampling probabilities themselves: the density of cell i is
//    n (cdf[i+1] - cdf[i]) (equal to w_i / mean(w) up to double rounding), so the pdf a sample
//    reports is exactly the probability with which its cell was chosen, and pdf(x) gives the same
//    bits for the same cell.
//  - Weights are sanitised, not asserted (release builds drop asserts): a negative or NaN weight
//    counts as 0 and +inf as the largest float. Callers that must refuse such input (an
//    environment map's pixels) validate it first and say where it is.
//  - All weights 0 (or no weights): the distribution falls back to uniform (density 1
//    everywhere), so sample() still returns points; integral() then reports 0, so a caller
//    that weighs strategies by integral() never picks this one.
//
// Guarantees: for every u (even u outside [0,1), which is clamped, and NaN, taken as 0),
// sample() returns x in [0,1) inside the cell it reports (floor(x n) == offset exactly), never
// x == 1, and never a cell of zero weight (unless all are zero). Everything is deterministic:
// the same weights and u give the same bits.
//
// Cells per dimension: at most 2^24, so that every cell [i/n, (i+1)/n) holds a float.
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "common/math/vec.h"

namespace lensfarm {

// The cell of [0,1) cut into n equal cells that holds x: floor(x n), computed exactly in double
// (x has 24 significant bits and n at most 2^24, so x n is exact), clamped to [0, n-1] (x == 1
// is in the last cell). Both sampling and lookups (EnvironmentMap) use this one definition.
inline int cellIndex(float x, int n) {
  const double c = std::floor(double(x) * double(n));
  if (!(c >= 0.0)) return 0;  // also NaN
  return c >= double(n) ? n - 1 : int(c);
}

class Distribution1D {
 public:
  // n = weights.size() cells over [0,1): the density is proportional to weights[i] on
  // [i/n, (i+1)/n). See the top of the file for zero, negative and non-finite weights.
  explicit Distribution1D(std::span<const float> weights);
  // The same from double weights (Distribution2D's row integrals, which a float could round to
  // 0). Weights above the largest float count as the largest float, as +inf does.
  explicit Distribution1D(std::span<const double> weights);

  int size() const { return n_; }

  // The integral over [0,1) of the (sanitised) step function: the mean weight. 0 if all are 0.
  double integral() const { return integral_; }
  // True when the distribution fell back to uniform because every weight was 0.
  bool isUniformFallback() const { return uniformFallback_; }

  // Continuous sample: x in [0,1) with density pdf(x) relative to [0,1) (stored in *pdf), in
  // cell *offset. Inverts the cdf, so x is monotone in u.
  float sample(float u, float* pdf = nullptr, int* offset = nullptr) const;

  // Discrete sample: a cell with probability pmf(cell) (stored in *pmf); *uRemapped is where u
  // fell inside that cell's share of [0,1), rescaled to [0,1), so it can be reused.
  int sampleDiscrete(float u, float* pmf = nullptr, float* uRemapped = nullptr) const;

  // The density at x relative to [0,1); 0 outside [0,1] (x == 1 counts as the last cell).
  float pdf(float x) const;
  // The probability of cell i (0 outside [0, n)).
  float pmf(int i) const;

  // The cdf at x, the inverse of sample(): invert(sample(u)) == u up to rounding.
  float invert(float x) const;

 private:
  int findCell(double u) const;

  int n_ = 0;
  std::vector<double> cdf_;  // n + 1 entries, cdf_[0] == 0, cdf_[n] == 1, non-decreasing
  double integral_ = 0.0;
  bool uniformFallback_ = false;
};

// A density on [0,1)^2 proportional to a row-major grid of weights: nu columns (along x) by nv
// rows (along y), row v covering y in [v/nv, (v+1)/nv). Sampled as pbrt does: a row from the
// marginal distribution of the row integrals, then x from that row's conditional distribution;
// the joint density is their product.
//
// Memory: 8 bytes per cell (the conditional cdfs), so a 4096 x 2048 grid takes 64 MiB.
class Distribution2D {
 public:
  // weights.size() must be nu * nv with nu, nv >= 1 (std::invalid_argument otherwise: a
  // programming error, not bad input). Zero, negative and non-finite weights as in 1D.
  Distribution2D(std::span<const float> weights, int nu, int nv);

  int width() const { return nu_; }
  int height() const { return nv_; }

  // The integral over [0,1)^2: the mean weight (0 if all are 0; sampling is then uniform).
  double integral() const { return marginal_.integral(); }

  // A point of [0,1)^2 with its density (relative to the unit square) and its cell (column, row).
  Vec2 sample(Vec2 u, float* pdf = nullptr, glm::ivec2* cell = nullptr) const;
  // The density at uv (0 outside [0,1]^2): the same bits sample() reports for that point.
  float pdf(Vec2 uv) const;

 private:
  int nu_, nv_;
  std::vector<Distribution1D> conditional_;  // one per row, over x
  Distribution1D marginal_;                  // over rows, weights = the rows' integrals
};

}  // namespace lensfarm
