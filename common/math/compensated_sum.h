#pragma once
// Neumaier's compensated summation. The sensor adds one value per unit of work to each cell
// for as long as a job runs (billions of samples); a plain double would drift by up to
// n * 2^-53 relative, this keeps the error at a few ulps independent of n.
#include <cmath>

namespace lensfarm {

class CompensatedSum {
 public:
  void add(double x) {
    const double t = sum_ + x;
    if (std::abs(sum_) >= std::abs(x))
      compensation_ += (sum_ - t) + x;
    else
      compensation_ += (x - t) + sum_;
    sum_ = t;
  }
  double value() const { return sum_ + compensation_; }

 private:
  double sum_ = 0.0;
  double compensation_ = 0.0;
};

}  // namespace lensfarm
