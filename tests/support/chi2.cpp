#include "tests/support/chi2.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>
#include <utility>
#include <vector>

namespace lensfarm::test {

Pcg32::Pcg32(uint64_t seed, uint64_t stream) : inc_((stream << 1u) | 1u) {
  next();
  state_ += seed;
  next();
}

uint32_t Pcg32::next() {
  const uint64_t old = state_;
  state_ = old * 6364136223846793005ULL + inc_;
  const auto xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
  const auto rot = uint32_t(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

namespace {

constexpr double kPiD = std::numbers::pi;

// Integrates pdf(w) sin(theta) over [th0, th1] x [ph0, ph1] by adaptive Gauss-Legendre cubature
// (4 x 4 points per rectangle). An open rule: the pdf is never evaluated on a cell's edges, so a
// discontinuity there (a hemisphere's rim on theta = pi/2) is integrated exactly.
class CellIntegrator {
 public:
  CellIntegrator(const DirectionPdf& pdf, const Chi2Options& o) : pdf_(pdf), o_(o) {}

  double integrate(double th0, double th1, double ph0, double ph1, int minDepth) {
    return recurse(th0, th1, ph0, ph1, 0, minDepth, gauss(th0, th1, ph0, ph1));
  }
  uint64_t invalidValues() const { return invalid_; }

 private:
  double f(double theta, double phi) {
    const double s = std::sin(theta);
    const Vec3 w(float(s * std::cos(phi)), float(s * std::sin(phi)), float(std::cos(theta)));
    const double p = double(pdf_(w));
    if (!std::isfinite(p) || p < 0.0) {
      ++invalid_;
      return 0.0;
    }
    return p * s;
  }

  double gauss(double th0, double th1, double ph0, double ph1) {
    // 4-point Gauss-Legendre nodes and weights on [-1, 1]; exact for degree 7 per dimension.
    static constexpr double x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
    static constexpr double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
    const double ct = 0.5 * (th0 + th1), ht = 0.5 * (th1 - th0), cp = 0.5 * (ph0 + ph1), hp = 0.5 * (ph1 - ph0);
    double sum = 0.0;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) sum += w[i] * w[j] * f(ct + ht * x[i], cp + hp * x[j]);
    return sum * ht * hp;
  }

  // `whole` is this rectangle's own estimate; its four quarters' sum replaces it when they agree
  // within the tolerance of Chi2Options.
  double recurse(double th0, double th1, double ph0, double ph1, int depth, int minDepth, double whole) {
    const double thm = 0.5 * (th0 + th1), phm = 0.5 * (ph0 + ph1);
    const double q[4] = {gauss(th0, thm, ph0, phm), gauss(th0, thm, phm, ph1), gauss(thm, th1, ph0, phm),
                         gauss(thm, th1, phm, ph1)};
    const double parts = q[0] + q[1] + q[2] + q[3];
    const double share = (th1 - th0) * (ph1 - ph0) / (2.0 * kPiD * kPiD);
    const double tolerance = std::max({o_.relTolerance * std::abs(parts), o_.absTolerance * share,
                                       o_.statTolerance * std::sqrt(std::abs(parts) / double(o_.sampleCount))});
    if (depth + 1 >= o_.maxDepth || (depth + 1 >= minDepth && std::abs(parts - whole) <= tolerance)) return parts;
    return recurse(th0, thm, ph0, phm, depth + 1, minDepth, q[0]) +
           recurse(th0, thm, phm, ph1, depth + 1, minDepth, q[1]) +
           recurse(thm, th1, ph0, phm, depth + 1, minDepth, q[2]) +
           recurse(thm, th1, phm, ph1, depth + 1, minDepth, q[3]);
  }

  const DirectionPdf& pdf_;
  const Chi2Options& o_;
  uint64_t invalid_ = 0;
};

// One character per cell of the residual map: (observed - expected) / sqrt(expected).
char residualChar(double observed, double expected) {
  if (expected <= 0.0) return observed > 0.0 ? '!' : ' ';
  const double r = (observed - expected) / std::sqrt(expected);
  const double a = std::abs(r);
  if (a < 2.0) return '.';
  if (a < 3.0) return r > 0 ? '+' : '-';
  if (a < 5.0) return r > 0 ? 'P' : 'M';
  return r > 0 ? '#' : '=';
}

}  // namespace

Chi2Result chi2Test(const DirectionSampler& sample, const DirectionPdf& pdf, const Chi2Options& options) {
  Chi2Options o = options;
  if (o.phiBins <= 0) o.phiBins = 2 * o.thetaBins;
  const int nt = o.thetaBins, np = o.phiBins;
  const size_t cells = size_t(nt) * size_t(np);
  Chi2Result result;

  // 1. Histogram of the samples.
  std::vector<double> observed(cells, 0.0);
  Pcg32 rng(o.seed);
  uint64_t accepted = 0;
  for (uint64_t k = 0; k < o.sampleCount; ++k) {
    const float u0 = rng.uniform(), u1 = rng.uniform(), uLobe = rng.uniform();
    const std::optional<Vec3> d = sample(Vec2(u0, u1), uLobe);
    if (!d) continue;
    ++accepted;
    const DVec3 w(*d);
    const double len2 = glm::dot(w, w);
    if (!std::isfinite(len2) || std::abs(len2 - 1.0) > 1e-3) {
      ++result.invalidSamples;
      continue;
    }
    const DVec3 n = w / std::sqrt(len2);
    const double theta = std::acos(std::clamp(n.z, -1.0, 1.0));
    double phi = std::atan2(n.y, n.x);
    if (phi < 0.0) phi += 2.0 * kPiD;
    const int i = std::min(int(theta / kPiD * nt), nt - 1);
    const int j = std::min(int(phi / (2.0 * kPiD) * np), np - 1);
    observed[size_t(i) * size_t(np) + size_t(j)] += 1.0;
  }
  result.acceptedFraction = double(accepted) / double(o.sampleCount);

  // 2. Expected counts. A second pass re-integrates, 4^refineDepth times finer, the cells whose
  // samples disagree with the first estimate (samples where it found no probability, or a
  // deviation beyond 4 standard deviations): the first pass can step over a feature narrower
  // than its points (a GGX lobe of alpha = 0.01 at the pole, cut by the visibility of grazing
  // normals). This only makes the expected counts more accurate; it cannot make a wrong sampler
  // agree with its pdf.
  std::vector<double> integral(cells, 0.0);
  CellIntegrator integrator(pdf, o);
  auto integrateCell = [&](int i, int j, int minDepth) {
    return integrator.integrate(kPiD * i / nt, kPiD * (i + 1) / nt, 2.0 * kPiD * j / np, 2.0 * kPiD * (j + 1) / np,
                                minDepth);
  };
  for (int i = 0; i < nt; ++i)
    for (int j = 0; j < np; ++j) integral[size_t(i) * size_t(np) + size_t(j)] = integrateCell(i, j, o.minDepth);
  std::vector<std::pair<double, size_t>> disagreeing;  // (deviation, cell)
  for (size_t c = 0; c < cells; ++c) {
    const double ex = integral[c] * double(o.sampleCount);
    if (observed[c] <= 0.0) continue;
    if (ex <= 0.0) {
      disagreeing.emplace_back(std::numeric_limits<double>::infinity(), c);
    } else if (std::abs(observed[c] - ex) > 4.0 * std::sqrt(ex) + 2.0) {
      disagreeing.emplace_back(std::abs(observed[c] - ex) / std::sqrt(ex), c);
    }
  }
  // The worst first, and not too many: when hundreds of cells disagree the sampler is wrong.
  std::sort(disagreeing.begin(), disagreeing.end(), std::greater<>());
  if (disagreeing.size() > size_t(o.maxRefinedCells)) disagreeing.resize(size_t(o.maxRefinedCells));
  for (const auto& [deviation, c] : disagreeing) {
    integral[c] = integrateCell(int(c / size_t(np)), int(c % size_t(np)), o.minDepth + o.refineDepth);
    ++result.refinedCells;
  }
  std::vector<double> expected(cells, 0.0);
  for (size_t c = 0; c < cells; ++c) {
    result.pdfIntegral += integral[c];
    expected[c] = integral[c] * double(o.sampleCount);
  }
  result.invalidPdfValues = integrator.invalidValues();

  // 3. and 4. Pool the cells expecting few samples (in increasing order of expectation, as in
  // Mitsuba: a pool still short of minExpected takes in the next cell), then chi2.
  std::vector<size_t> order(cells);
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pooledObserved = 0.0, pooledExpected = 0.0;
  for (size_t c : order) {
    if (expected[c] <= 0.0) {
      result.samplesWherePdfIsZero += uint64_t(observed[c]);
      continue;
    }
    if (expected[c] < o.minExpected || (pooledExpected > 0.0 && pooledExpected < o.minExpected)) {
      pooledObserved += observed[c];
      pooledExpected += expected[c];
      ++result.pooledCells;
    } else {
      const double diff = observed[c] - expected[c];
      result.chi2 += diff * diff / expected[c];
      ++result.dof;
    }
  }
  if (pooledExpected > 0.0) {
    const double diff = pooledObserved - pooledExpected;
    result.chi2 += diff * diff / pooledExpected;
    ++result.dof;
  }
  result.dof -= 1;
  if (result.invalidSamples > 0 || result.invalidPdfValues > 0 || result.samplesWherePdfIsZero > 0) {
    result.pValue = 0.0;
  } else if (result.dof <= 0) {
    result.pValue = std::numeric_limits<double>::quiet_NaN();
  } else {
    result.pValue = chi2PValue(result.chi2, result.dof);
  }

  // The dump: summary, residual map (downsampled to at most 40 x 80 characters), worst cells.
  std::ostringstream out;
  out << "chi2 = " << result.chi2 << ", dof = " << result.dof << ", p-value = " << result.pValue
      << "\npdf integral = " << result.pdfIntegral << ", accepted fraction = " << result.acceptedFraction << " ("
      << o.sampleCount << " samples, " << nt << " x " << np << " cells, " << result.pooledCells << " pooled, "
      << result.refinedCells << " integrated again)\n";
  if (result.invalidSamples) out << result.invalidSamples << " samples were not unit directions\n";
  if (result.invalidPdfValues) out << result.invalidPdfValues << " pdf values were negative or not finite\n";
  if (result.samplesWherePdfIsZero) out << result.samplesWherePdfIsZero << " samples fell where the pdf is 0\n";
  if (result.dof <= 0) out << "no degrees of freedom: the samples are all in one cell\n";
  const int rowStep = (nt + 39) / 40, colStep = (np + 79) / 80;
  out << "residual map (observed - expected) / sqrt(expected), rows theta 0..pi, columns phi 0..2pi;\n"
         "'.' < 2, '+'/'-' < 3, 'P'/'M' < 5, '#'/'=' >= 5 (excess / deficit), '!' samples where pdf = 0:\n";
  for (int i = 0; i < nt; i += rowStep) {
    for (int j = 0; j < np; j += colStep) {
      double ob = 0.0, ex = 0.0;
      for (int a = i; a < std::min(nt, i + rowStep); ++a)
        for (int b = j; b < std::min(np, j + colStep); ++b) {
          ob += observed[size_t(a) * size_t(np) + size_t(b)];
          ex += expected[size_t(a) * size_t(np) + size_t(b)];
        }
      out << residualChar(ob, ex);
    }
    out << '\n';
  }
  std::vector<size_t> worst(cells);
  std::iota(worst.begin(), worst.end(), size_t(0));
  auto score = [&](size_t c) {
    return expected[c] > 0.0 ? std::abs(observed[c] - expected[c]) / std::sqrt(expected[c])
                             : (observed[c] > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  };
  const size_t shown = std::min<size_t>(8, cells);
  std::partial_sort(worst.begin(), worst.begin() + long(shown), worst.end(),
                    [&](size_t a, size_t b) { return score(a) > score(b); });
  out << "worst cells:\n";
  for (size_t k = 0; k < shown; ++k) {
    const size_t c = worst[k];
    const double i = double(c / size_t(np)), j = double(c % size_t(np));
    char line[200];
    std::snprintf(line, sizeof line, "  theta [%.4f, %.4f] phi [%.4f, %.4f]: observed %.0f, expected %.2f\n",
                  kPiD * i / nt, kPiD * (i + 1) / nt, 2 * kPiD * j / np, 2 * kPiD * (j + 1) / np, observed[c],
                  expected[c]);
    out << line;
  }
  result.histogramDump = out.str();
  return result;
}

double regularizedGammaQ(double a, double x) {
  if (!(a > 0.0) || !(x >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0.0) return 1.0;
  constexpr double kEps = 1e-15, kTiny = 1e-300;
  constexpr int kMaxIterations = 10000000;
  // log(x^a e^-x / Gamma(a)), the common prefactor.
  const double logPrefactor = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    // P(a, x) = prefactor * sum_n x^n / (a (a+1) ... (a+n)); Q = 1 - P (here Q is not small).
    double term = 1.0 / a, sum = term, ap = a;
    for (int n = 0; n < kMaxIterations; ++n) {
      ap += 1.0;
      term *= x / ap;
      sum += term;
      if (std::abs(term) < std::abs(sum) * kEps) break;
    }
    return std::clamp(1.0 - sum * std::exp(logPrefactor), 0.0, 1.0);
  }
  // Q(a, x) = prefactor * 1 / (x + 1 - a - 1 (1 - a) / (x + 3 - a - 2 (2 - a) / (x + 5 - a - ...))),
  // by the modified Lentz method.
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEps) break;
  }
  return std::clamp(std::exp(logPrefactor) * h, 0.0, 1.0);
}

double chi2PValue(double chi2, int dof) { return regularizedGammaQ(0.5 * dof, 0.5 * chi2); }

double sidakThreshold(double significance, int testCount) {
  // 1 - (1 - alpha)^(1/n), without the cancellation of 1 - (something close to 1).
  return -std::expm1(std::log1p(-significance) / double(testCount));
}

bool passes(double pValue, double significance, int testCount) {
  return pValue >= sidakThreshold(significance, testCount);  // false for NaN
}

}  // namespace lensfarm::test
