// The BALANCE board's loop trace helpers (docs/protocol.md section 10; the board's side is in balance_trace.cpp):
//   Excitation      a known test signal (step, chirp, PRBS) added to the pitch setpoint, for measuring the loop;
//   FlightRecorder  a RAM ring of the last 5 s of loop records, frozen at a latch, sent by `trace dump`.
// Both are plain values: no heap, O(1) per loop iteration.
#pragma once

#include <cstddef>
#include <cstdint>

#include "saulfw/hal.hpp"
#include "saulproto/core/trace.hpp"

namespace saul::fw {

/// A test signal for the pitch setpoint. It ends by itself after its duration; the board stops it at once when it
/// may not run (BalanceBoard::excite_check).
class Excitation {
 public:
  static constexpr TimeUs kPrbsBitUs = 20'000;  ///< a PRBS bit lasts 20 ms (flat spectrum to ~20 Hz)

  void start(const trace::ExciteStart& signal, TimeUs now) noexcept;
  void stop() noexcept;
  /// Advances to now and returns the offset (degrees); 0 when none runs. Ends the signal after its duration.
  float update(TimeUs now) noexcept;
  [[nodiscard]] trace::Excite kind() const noexcept { return kind_; }
  [[nodiscard]] bool active() const noexcept { return kind_ != trace::Excite::none; }
  [[nodiscard]] float offset_deg() const noexcept { return offset_deg_; }

 private:
  trace::Excite kind_ = trace::Excite::none;
  trace::ExciteStart signal_{};
  TimeUs start_us_ = 0;
  TimeUs next_bit_us_ = 0;
  std::uint16_t lfsr_ = 0x1FF;  // PRBS9: x^9 + x^5 + 1
  float offset_deg_ = 0.0F;
};

/// The last kRecords loop records in RAM. Frozen, it keeps them until arm().
class FlightRecorder {
 public:
  static constexpr std::size_t kRecords = 5000;                               ///< 5 s at 1 kHz
  static constexpr std::size_t kBytes = kRecords * trace::kPayloadLength;     ///< 175 000 bytes
  static_assert(kBytes == 175'000);

  /// Keeps a record unless frozen (the oldest one goes when full).
  void record(const trace::LoopTrace& r) noexcept;
  void freeze(TimeUs now, const char* why) noexcept;
  /// Forgets the records and records again.
  void arm() noexcept;
  [[nodiscard]] bool frozen() const noexcept { return frozen_; }
  [[nodiscard]] std::size_t size() const noexcept { return count_; }
  [[nodiscard]] TimeUs frozen_us() const noexcept { return frozen_us_; }
  [[nodiscard]] const char* why() const noexcept { return why_; }
  /// The i-th oldest record, i < size().
  [[nodiscard]] trace::LoopTrace at(std::size_t i) const noexcept;

 private:
  std::uint8_t ring_[kBytes]{};
  std::size_t next_ = 0;  // where the next record goes
  std::size_t count_ = 0;
  bool frozen_ = false;
  TimeUs frozen_us_ = 0;
  const char* why_ = "";
};

}  // namespace saul::fw
