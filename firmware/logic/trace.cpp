#include "saulfw/trace.hpp"

#include <cmath>

namespace saul::fw {

void Excitation::start(const trace::ExciteStart& signal, TimeUs now) noexcept {
  signal_ = signal;
  kind_ = signal.kind;
  start_us_ = now;
  next_bit_us_ = now;
  lfsr_ = 0x1FF;
  offset_deg_ = 0.0F;
}

void Excitation::stop() noexcept {
  kind_ = trace::Excite::none;
  offset_deg_ = 0.0F;
}

float Excitation::update(TimeUs now) noexcept {
  if (kind_ == trace::Excite::none) return 0.0F;
  const TimeUs elapsed = now > start_us_ ? now - start_us_ : 0;
  const auto t = static_cast<float>(elapsed) * 1e-6F;
  if (!(t < signal_.duration_s)) {
    stop();
    return 0.0F;
  }
  const float a = signal_.amplitude_deg;
  switch (kind_) {
    case trace::Excite::step:
      offset_deg_ = a;
      break;
    case trace::Excite::chirp: {
      // A linear chirp: the frequency goes from f0 to f1 over the duration. The phase in cycles is
      // f0 t + (f1 - f0) t^2 / (2 T); only its fraction matters, taken before sin() to keep float precision.
      const float cycles = signal_.f0_hz * t + (signal_.f1_hz - signal_.f0_hz) * t * t / (2.0F * signal_.duration_s);
      const float fraction = cycles - std::floor(cycles);
      offset_deg_ = a * std::sin(6.2831853F * fraction);
      break;
    }
    case trace::Excite::prbs:
      while (now >= next_bit_us_) {  // one LFSR shift per bit period
        const auto bit = static_cast<std::uint16_t>(((lfsr_ >> 8) ^ (lfsr_ >> 4)) & 1U);
        lfsr_ = static_cast<std::uint16_t>(((lfsr_ << 1) | bit) & 0x1FF);
        next_bit_us_ += kPrbsBitUs;
      }
      offset_deg_ = (lfsr_ & 1U) != 0 ? a : -a;
      break;
    case trace::Excite::none: break;
  }
  return offset_deg_;
}

void FlightRecorder::record(const trace::LoopTrace& r) noexcept {
  if (frozen_) return;
  trace::write_payload(r, ring_ + next_ * trace::kPayloadLength);
  next_ = next_ + 1 == kRecords ? 0 : next_ + 1;
  if (count_ < kRecords) ++count_;
}

void FlightRecorder::freeze(TimeUs now, const char* why) noexcept {
  if (frozen_) return;
  frozen_ = true;
  frozen_us_ = now;
  why_ = why;
}

void FlightRecorder::arm() noexcept {
  next_ = 0;
  count_ = 0;
  frozen_ = false;
  why_ = "";
}

trace::LoopTrace FlightRecorder::at(std::size_t i) const noexcept {
  const std::size_t oldest = count_ < kRecords ? 0 : next_;
  const std::size_t slot = (oldest + i) % kRecords;
  return trace::decode_payload(std::span<const std::uint8_t>(ring_ + slot * trace::kPayloadLength,
                                                             trace::kPayloadLength))
      .value();
}

}  // namespace saul::fw
