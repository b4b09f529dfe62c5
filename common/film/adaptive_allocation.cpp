#include "common/film/adaptive_allocation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

namespace lensfarm {

namespace {
constexpr uint64_t kMagic = 0x31764f4c4c414c4cull;  // "LLALLOv1"

// Per block of `map`: its cells, the samples each cell holds so far (and map.first, half of them)
// and its per-sample standard deviation; every cell of a block must hold the same even count.
void measureBlocks(const Sensor& film, const ConvergenceTracker& halves, const AllocationRequest& request,
                   SampleMap& map, std::vector<double>& cells, std::vector<double>& sigma, std::vector<double>& held) {
  const int width = film.width(), height = film.height();
  for (int by = 0; by < map.blocksY; ++by)
    for (int bx = 0; bx < map.blocksX; ++bx) {
      const size_t b = size_t(by) * size_t(map.blocksX) + size_t(bx);
      const int x0 = bx * request.blockEdge, y0 = by * request.blockEdge;
      const int x1 = std::min(width, x0 + request.blockEdge), y1 = std::min(height, y0 + request.blockEdge);
      const uint64_t n = film.samples(x0, y0);
      if (n % 2 != 0) throw std::invalid_argument("allocateRound: a cell holds an odd number of samples");
      double variance = 0.0;
      for (int j = y0; j < y1; ++j)
        for (int i = x0; i < x1; ++i) {
          if (film.samples(i, j) != n)
            throw std::invalid_argument("allocateRound: a block's cells hold different counts");
          variance += std::max(0.0, halves.cellVariance(film, i, j));
        }
      cells[b] = double(x1 - x0) * double(y1 - y0);
      sigma[b] = std::isfinite(variance) ? std::sqrt(variance / cells[b]) : 0.0;
      held[b] = double(n);
      map.first[b] = n / 2;
    }
}

// Whole samples: round down, then hand the rest out by the largest remainder (block order
// breaks ties), never past the budget or the cap. Writes map.count.
void wholeSamples(const std::vector<double>& share, const std::vector<double>& cells, double budget, double hi,
                  SampleMap& map) {
  const size_t blocks = share.size();
  double left = budget;
  std::vector<size_t> order(blocks);
  for (size_t k = 0; k < blocks; ++k) {
    map.count[k] = uint32_t(std::min(std::floor(share[k]), hi));
    left -= cells[k] * map.count[k];
    order[k] = k;
  }
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) {
    return share[x] - std::floor(share[x]) > share[y] - std::floor(share[y]);
  });
  for (size_t k : order)
    if (cells[k] <= left && map.count[k] + 1 <= hi) {
      ++map.count[k];
      left -= cells[k];
    }
}
}  // namespace

std::shared_ptr<const SampleMap> RoundAllocation::mapOf(uint64_t u) const {
  if (u < start || u >= start + units) throw std::invalid_argument("RoundAllocation::mapOf: unit outside the round");
  auto map = std::make_shared<SampleMap>(base);
  map->half = uint32_t(u & 1);
  const uint64_t before = (u - start) / 2;  // the round's earlier units in the same half
  for (size_t b = 0; b < map->first.size(); ++b) map->first[b] += before * map->count[b];
  return map;
}

RoundAllocation allocateRound(const Sensor& film, const ConvergenceTracker& halves, const AllocationRequest& request) {
  const int width = film.width(), height = film.height();
  if (request.units == 0 || request.units % 2 != 0 || request.passSamples == 0 || request.blockEdge < 1)
    throw std::invalid_argument(
        "allocateRound: a round is an even number of units of at least 1 sample, blocks of at least 1 cell");
  RoundAllocation round;
  round.start = request.start;
  round.units = request.units;
  SampleMap& map = round.base;
  map.passSamples = request.passSamples;
  map.blockEdge = request.blockEdge;
  map.blocksX = SampleMap::blocksAlong(width, request.blockEdge);
  map.blocksY = SampleMap::blocksAlong(height, request.blockEdge);
  const size_t blocks = size_t(map.blocksX) * size_t(map.blocksY);
  map.first.assign(blocks, 0);
  map.count.assign(blocks, 0);

  // Each block's cells, samples so far and per-sample standard deviation.
  std::vector<double> cells(blocks, 0.0), sigma(blocks, 0.0), held(blocks, 0.0);
  measureBlocks(film, halves, request, map, cells, sigma, held);

  // Per unit: at least `lo`, at most `hi` samples a cell; in all, P a cell on average.
  const double totalCells = double(width) * double(height);
  const double budget = double(request.passSamples) * totalCells;
  const double lo = std::max(1.0, std::floor(request.floor * request.passSamples));
  const double hi = std::max(lo, kAllocationCap * request.passSamples);
  const double rounds = double(request.units);
  const auto perUnit = [&](size_t b, double lambda) {
    return std::clamp((lambda * sigma[b] - held[b]) / rounds, lo, hi);
  };
  const auto spent = [&](double lambda) {
    double s = 0.0;
    for (size_t b = 0; b < blocks; ++b) s += cells[b] * perUnit(b, lambda);
    return s;
  };
  std::vector<double> share(blocks, double(request.passSamples));
  const double maxSigma = *std::max_element(sigma.begin(), sigma.end());
  if (maxSigma > 0.0 && spent(0.0) < budget) {
    // lambda between 0 and one that gives every block of positive sigma the cap: bisection on a
    // nondecreasing function, a fixed number of steps (deterministic).
    double a = 0.0, b = 1.0;
    while (spent(b) < budget && b < 1e300) b *= 2.0;
    for (int step = 0; step < 200; ++step) {
      const double m = 0.5 * (a + b);
      (spent(m) < budget ? a : b) = m;
    }
    for (size_t k = 0; k < blocks; ++k) share[k] = perUnit(k, b);
  }
  wholeSamples(share, cells, budget, hi, map);
  return round;
}

std::string RoundAllocation::serialize() const {
  const size_t blocks = base.count.size();
  const uint64_t header[8] = {
      kMagic, start, units, base.passSamples, uint64_t(base.blockEdge), uint64_t(base.blocksX), uint64_t(base.blocksY),
      blocks};
  std::string out(sizeof header + blocks * (sizeof(uint64_t) + sizeof(uint32_t)), '\0');
  std::memcpy(out.data(), header, sizeof header);
  std::memcpy(out.data() + sizeof header, base.first.data(), blocks * sizeof(uint64_t));
  std::memcpy(out.data() + sizeof header + blocks * sizeof(uint64_t), base.count.data(), blocks * sizeof(uint32_t));
  return out;
}

RoundAllocation RoundAllocation::deserialize(const std::string& bytes) {
  uint64_t header[8];
  if (bytes.size() < sizeof header) throw std::runtime_error("sample allocation: truncated");
  std::memcpy(header, bytes.data(), sizeof header);
  const uint64_t blocks = header[7];
  if (header[0] != kMagic || header[2] == 0 || header[2] > UINT32_MAX || header[3] == 0 || header[3] > UINT32_MAX ||
      header[4] == 0 || header[4] > (1u << 16) || header[5] > (1u << 16) || header[6] > (1u << 16) ||
      blocks != header[5] * header[6] || bytes.size() != sizeof header + blocks * (sizeof(uint64_t) + sizeof(uint32_t)))
    throw std::runtime_error("sample allocation: not a lensfarm allocation");
  RoundAllocation r;
  r.start = header[1];
  r.units = uint32_t(header[2]);
  r.base.passSamples = uint32_t(header[3]);
  r.base.blockEdge = int(header[4]);
  r.base.blocksX = int(header[5]);
  r.base.blocksY = int(header[6]);
  r.base.first.resize(blocks);
  r.base.count.resize(blocks);
  std::memcpy(r.base.first.data(), bytes.data() + sizeof header, blocks * sizeof(uint64_t));
  std::memcpy(r.base.count.data(), bytes.data() + sizeof header + blocks * sizeof(uint64_t), blocks * sizeof(uint32_t));
  return r;
}

}  // namespace lensfarm
