// AuditBook: one job's units under audit and their verdicts (audit.h).
#include "coordinator/core/audit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lensfarm {

std::optional<std::string> sumsDiffer(const std::vector<double>& a, const std::vector<double>& b, double tolerance,
                                      int channels) {
  if (a.size() != b.size())
    return "differ in size (" + std::to_string(a.size()) + " and " + std::to_string(b.size()) + " sums)";
  // The largest relative difference beyond the tolerance, and its cell. Sums are finite
  // (Coordinator::checkPlausible), so max(|a|, |b|) is 0 only where both are.
  double worst = 0.0;
  size_t worstAt = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    if (a[k] == b[k]) continue;
    const double scale = std::max(std::abs(a[k]), std::abs(b[k]));
    const double relative = std::abs(a[k] - b[k]) / scale;
    if (relative > tolerance && relative > worst) {
      worst = relative;
      worstAt = k;
    }
  }
  if (worst == 0.0) return std::nullopt;
  char text[96];
  std::snprintf(text, sizeof text, "differ by up to %.1e (cell %zu)", worst, worstAt / size_t(std::max(channels, 1)));
  return std::string(text);
}

bool differenceLooksLikeRounding(const std::vector<double>& a, const std::vector<double>& b, double tolerance,
                                 int channels) {
  if (a.size() != b.size() || a.empty()) return false;
  const size_t stride = size_t(std::max(channels, 1));
  size_t cellsDiffering = 0;
  double squaredDifference = 0.0, squaredMean = 0.0;
  for (size_t cell = 0; cell * stride < a.size(); ++cell) {
    bool differs = false;
    for (size_t k = cell * stride; k < std::min(a.size(), (cell + 1) * stride); ++k) {
      const double d = a[k] - b[k], mean = 0.5 * (a[k] + b[k]);
      squaredDifference += d * d;
      squaredMean += mean * mean;
      differs = differs || std::abs(d) > tolerance * std::max(std::abs(a[k]), std::abs(b[k]));
    }
    cellsDiffering += differs;
  }
  const double cells = double((a.size() + stride - 1) / stride);
  return double(cellsDiffering) <= kRoundingCells * cells &&
         squaredDifference <= kRoundingRmse * kRoundingRmse * squaredMean;
}

uint64_t rewindPointSpacing(double auditFraction) {
  // A worker is audited about every 1 / fraction of its units: copies at half that spacing.
  return auditFraction > 0.0 ? uint64_t(std::ceil(std::min(0.5 / auditFraction, 1e6))) : 0;
}

const AuditBook::Audit* AuditBook::find(uint64_t unit) const {
  auto it = audits_.find(unit);
  return it == audits_.end() ? nullptr : &it->second;
}

void AuditBook::open(uint64_t unit, Claim counted, uint64_t acceptedSeq) {
  Audit& a = audits_[unit];
  a = Audit{};
  a.renderedBy.insert(counted.worker);
  a.counted = std::move(counted);
  a.acceptedSeq = acceptedSeq;
}

bool AuditBook::offers(const std::string& worker) const {
  for (const auto& [unit, a] : audits_)
    if (!a.leasedTo && !a.renderedBy.count(worker)) return true;
  return false;
}

std::optional<uint64_t> AuditBook::lease(const std::string& worker) {
  for (auto& [unit, a] : audits_)
    if (!a.leasedTo && !a.renderedBy.count(worker)) {
      a.leasedTo = worker;
      a.renderedBy.insert(worker);
      return unit;
    }
  return std::nullopt;
}

void AuditBook::release(uint64_t unit, const std::string& worker) {
  auto it = audits_.find(unit);
  if (it == audits_.end() || it->second.leasedTo != worker) return;
  it->second.leasedTo.reset();
  it->second.renderedBy.erase(worker);
}

std::optional<AuditBook::Verdict> AuditBook::settle(uint64_t unit, Claim claim,
                                                    const std::optional<std::string>& fromCounted,
                                                    const std::optional<std::string>& fromDissent) {
  auto it = audits_.find(unit);
  if (it == audits_.end()) return std::nullopt;
  Audit& a = it->second;
  a.leasedTo.reset();
  a.renderedBy.insert(claim.worker);
  Verdict v;
  v.unit = unit;
  v.acceptedSeq = a.acceptedSeq;
  if (!a.dissent) {
    if (!fromCounted) {
      v.kind = Verdict::Kind::kAgreed;
      v.right = {a.counted.worker, claim.worker};
      audits_.erase(it);
    } else {
      v.kind = Verdict::Kind::kDisputed;
      v.right = {};
      v.detail = *fromCounted;
      a.dissent = std::move(claim);
    }
    return v;
  }
  const bool withCounted = !fromCounted, withDissent = !fromDissent;
  if (withCounted != withDissent) {
    v.kind = Verdict::Kind::kSettled;
    const Claim& agreed = withCounted ? a.counted : *a.dissent;
    const Claim& outvoted = withCounted ? *a.dissent : a.counted;
    v.right = {agreed.worker, claim.worker};
    v.wrong = outvoted.worker;
    v.detail = withCounted ? *fromDissent : *fromCounted;
  } else {
    // No two agree (or the third agrees with both, each within tolerance of a result the other
    // differs from): nobody is out-voted.
    v.kind = Verdict::Kind::kInconclusive;
    v.detail = fromCounted ? *fromCounted : std::string("agree with both");
  }
  audits_.erase(it);
  return v;
}

void AuditBook::forgetWorker(const std::string& worker) {
  for (auto it = audits_.begin(); it != audits_.end();) {
    Audit& a = it->second;
    if (a.counted.worker == worker) {
      it = audits_.erase(it);
      continue;
    }
    if (a.dissent && a.dissent->worker == worker) a.dissent.reset();
    if (a.leasedTo == worker) a.leasedTo.reset();
    ++it;
  }
}

}  // namespace lensfarm
