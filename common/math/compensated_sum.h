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

  // The exact state, for checkpoints: restoring it continues the sum bit for bit.
  double runningSum() const { return sum_; }
  double compensation() const { return compensation_; }
  static CompensatedSum fromState(double sum, double compensation) {
    CompensatedSum s;
    s.sum_ = sum;
    s.compensation_ = compensation;
    return s;
  }

 private:
  double sum_ = 0.0;
  double compensation_ = 0.0;
};

}  // namespace lensfarm
