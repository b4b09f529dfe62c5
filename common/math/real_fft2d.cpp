#include "common/math/real_fft2d.h"

#include <fftw3.h>

#include <mutex>
#include <new>

namespace lensfarm {

namespace {
std::mutex& plannerLock() {
  static std::mutex lock;
  return lock;
}
}  // namespace

RealFft2d::RealFft2d(int rows, int cols) : rows_(rows), cols_(cols) {
  const size_t reals = size_t(rows) * size_t(cols), complexes = size_t(rows) * size_t(cols / 2 + 1);
  std::lock_guard lock(plannerLock());
  real_ = fftw_alloc_real(reals);
  spectrum_ = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(complexes));
  if (!real_ || !spectrum_) {
    fftw_free(real_);
    fftw_free(spectrum_);
    throw std::bad_alloc();
  }
  fftw_complex* s = reinterpret_cast<fftw_complex*>(spectrum_);
  // FFTW_ESTIMATE leaves the arrays alone while planning; DESTROY_INPUT lets c2r use the fast paths.
  forwardPlan_ = fftw_plan_dft_r2c_2d(rows, cols, real_, s, FFTW_ESTIMATE);
  inversePlan_ = fftw_plan_dft_c2r_2d(rows, cols, s, real_, FFTW_ESTIMATE | FFTW_DESTROY_INPUT);
  for (size_t k = 0; k < reals; ++k) real_[k] = 0.0;
}

RealFft2d::~RealFft2d() {
  std::lock_guard lock(plannerLock());
  fftw_destroy_plan(static_cast<fftw_plan>(forwardPlan_));
  fftw_destroy_plan(static_cast<fftw_plan>(inversePlan_));
  fftw_free(real_);
  fftw_free(spectrum_);
}

void RealFft2d::forward() { fftw_execute(static_cast<fftw_plan>(forwardPlan_)); }
void RealFft2d::inverse() { fftw_execute(static_cast<fftw_plan>(inversePlan_)); }

int fftFriendlySize(int n) {
  for (int m = n < 1 ? 1 : n;; ++m) {
    int r = m;
    for (int p : {2, 3, 5, 7})
      while (r % p == 0) r /= p;
    if (r == 1) return m;
  }
}

}  // namespace lensfarm
