// A real FFT of one size through FFTW3 (Debian's libfftw3-dev): the plan is made once and reused for every window
// or segment of that size. Private to the tuning analysis.
#pragma once

#include <fftw3.h>

#include <complex>
#include <cstddef>
#include <span>

namespace saul::host::tune::detail {

class RealFft {
 public:
  explicit RealFft(std::size_t n);
  ~RealFft();
  RealFft(const RealFft&) = delete;
  RealFft& operator=(const RealFft&) = delete;

  [[nodiscard]] std::size_t size() const { return n_; }
  [[nodiscard]] std::size_t bins() const { return n_ / 2 + 1; }
  /// n samples in; forward() leaves bins() values in spectrum().
  [[nodiscard]] std::span<double> samples() { return {real_, n_}; }
  [[nodiscard]] std::span<std::complex<double>> spectrum() {
    return {reinterpret_cast<std::complex<double>*>(complex_), bins()};  // fftw_complex is double[2]: same layout
  }
  void forward() { fftw_execute(forward_); }
  /// spectrum() -> samples(), unnormalised (n times the inverse DFT), as FFTW computes it; spectrum() is lost.
  void inverse() { fftw_execute(inverse_); }

 private:
  void release() noexcept;
  std::size_t n_;
  double* real_;
  fftw_complex* complex_;
  fftw_plan forward_;
  fftw_plan inverse_;
};

}  // namespace saul::host::tune::detail
