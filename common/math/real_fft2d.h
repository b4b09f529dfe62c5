#pragma once
// A two-dimensional discrete Fourier transform of real data (FFTW, double precision), the one way
// lensfarm calls FFTW (film/diffraction_psf.h, film/psf_convolution.h).
//
// Conventions: a rows x cols real array, row-major; its spectrum is the rows x (cols / 2 + 1)
// half-plane of complex coefficients F(k, l) = sum_{r, c} f(r, c) exp(-2 pi i (k r / rows + l c / cols))
// (FFTW's r2c; the other half is the complex conjugate, F(-k, -l) = conj F(k, l)). inverse() is the
// unnormalised c2r: forward() then inverse() multiplies every value by rows x cols.
//
// Determinism: plans are made with FFTW_ESTIMATE (no timing measurements, so the same plan, and
// the same bits, for the same size on every run of a build), on arrays from fftw_malloc (the same
// alignment, so the same SIMD code paths), single-threaded. FFTW's planner is not thread-safe:
// plans are made and destroyed under one process-wide lock; executing them needs none.
#include <complex>
#include <cstddef>

namespace lensfarm {

class RealFft2d {
 public:
  RealFft2d(int rows, int cols);
  ~RealFft2d();
  RealFft2d(const RealFft2d&) = delete;
  RealFft2d& operator=(const RealFft2d&) = delete;

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int spectrumCols() const { return cols_ / 2 + 1; }
  double* data() { return real_; }                        // rows x cols, what forward() reads and inverse() writes
  std::complex<double>* spectrum() { return spectrum_; }  // rows x spectrumCols()

  void forward();  // data() -> spectrum()
  void inverse();  // spectrum() -> data(), unnormalised; spectrum() is overwritten

 private:
  int rows_, cols_;
  double* real_ = nullptr;
  std::complex<double>* spectrum_ = nullptr;
  void* forwardPlan_ = nullptr;
  void* inversePlan_ = nullptr;
};

// The smallest n' >= n whose only prime factors are 2, 3, 5 and 7 (sizes FFTW transforms fastest).
int fftFriendlySize(int n);

}  // namespace lensfarm
