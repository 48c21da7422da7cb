#include "fft.hpp"

#include <new>

namespace saul::host::tune::detail {

RealFft::RealFft(std::size_t n)
    : n_(n),
      real_(fftw_alloc_real(n)),
      complex_(fftw_alloc_complex(n / 2 + 1)),
      // FFTW_ESTIMATE: no timing runs, so the plan (and the result's last bits) do not depend on the machine's load.
      forward_(real_ && complex_ ? fftw_plan_dft_r2c_1d(static_cast<int>(n), real_, complex_, FFTW_ESTIMATE) : nullptr),
      inverse_(real_ && complex_ ? fftw_plan_dft_c2r_1d(static_cast<int>(n), complex_, real_, FFTW_ESTIMATE) : nullptr) {
  if (forward_ == nullptr || inverse_ == nullptr) {
    release();
    throw std::bad_alloc();
  }
}

RealFft::~RealFft() { release(); }

void RealFft::release() noexcept {
  if (forward_ != nullptr) fftw_destroy_plan(forward_);
  if (inverse_ != nullptr) fftw_destroy_plan(inverse_);
  fftw_free(real_);
  fftw_free(complex_);
}

}  // namespace saul::host::tune::detail
