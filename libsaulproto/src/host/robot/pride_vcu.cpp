#include "saulproto/host/robot/pride_vcu.hpp"

#include <array>
#include <stdexcept>

namespace saul::host {

using namespace std::chrono;

PrideVcu::PrideVcu(SerialPort& port, VcuClock clock, pride::VcuCommand command)
    : port_(port), clock_(std::move(clock)), command_(command), previous_command_(command) {
  if (!command.in_range())
    throw std::invalid_argument("pride: speed level must be 0..14 and FB, LR -100..+100");
  next_ = clock_();  // the first frame goes out at once
}

void PrideVcu::begin_neutral() {
  if (neutral_) return;
  neutral_ = true;
  previous_command_ = command_;
  command_.forward_back = 0;
  command_.left_right = 0;
}

bool PrideVcu::finished() const {
  if (!neutral_) return false;
  constexpr auto kNeeded = (kNeutralTime + kPeriod - microseconds(1)) / kPeriod;
  return counters_.neutral_frames_sent >= static_cast<std::uint64_t>(kNeeded);
}

void PrideVcu::send_frame(TimePoint now) {
  std::array<std::uint8_t, pride::kFrameSize> frame{};
  const auto n = pride::encode(command_, frame);
  if (!n) throw std::logic_error("pride: cannot encode the VCU frame");
  // On one wire every byte comes straight back; an echo that made no progress for kEchoTimeout is not coming.
  if (echo_.expected() > 0 && now - echo_progress_ > kEchoTimeout) echo_.clear();
  if (echo_.expected() == 0) echo_progress_ = now;
  port_.write(std::span<const std::uint8_t>(frame.data(), *n), milliseconds(5));
  const std::span<const std::uint8_t> sent(frame.data(), *n);
  if (!echo_.sent(sent)) {  // more echo outstanding than the filter holds: start over from this frame
    echo_.clear();
    echo_progress_ = now;
    echo_.sent(sent);
  }
  ++counters_.frames_sent;
  if (neutral_) ++counters_.neutral_frames_sent;
  // Absolute deadlines: the next frame is one period after this slot, not after now. When we are late by a
  // whole period or more, the missed slots are skipped (counted), never sent in a burst.
  next_ += kPeriod;
  while (next_ <= now) {
    next_ += kPeriod;
    ++counters_.missed_slots;
  }
}

void PrideVcu::take(std::span<const std::uint8_t> bytes, TimePoint now, const StatusHandler& on_status) {
  for (std::uint8_t b : bytes) {
    const auto kept = echo_.push(b);
    if (!kept) {
      echo_progress_ = now;
      continue;
    }
    const auto m = decoder_.push(*kept);
    if (!m) continue;
    if (const auto* s = std::get_if<pride::ControllerStatus>(&*m)) {
      ++counters_.controller_frames;
      last_status_ = *s;
      if (on_status) on_status(*s);
    } else if (const auto* v = std::get_if<pride::VcuCommand>(&*m); v && (*v == command_ || *v == previous_command_)) {
      ++counters_.late_echoes;  // a frame we sent, back after the filter forgot it: not someone else's
    } else {
      ++counters_.foreign_vcu_frames;
    }
  }
}

void PrideVcu::step(const StatusHandler& on_status) {
  auto now = clock_();
  if (now >= next_ && !finished()) send_frame(now);
  std::array<std::uint8_t, 256> buf{};
  while (true) {
    now = clock_();
    if (now >= next_) return;
    // Rounded up: a frame leaves at most 1 ms after its deadline, and we never spin.
    const auto left = ceil<milliseconds>(next_ - now);
    const std::size_t n = port_.read(buf, left);
    if (n == 0) return;  // timeout (the deadline) or a signal
    take(std::span<const std::uint8_t>(buf.data(), n), clock_(), on_status);
  }
}

}  // namespace saul::host
