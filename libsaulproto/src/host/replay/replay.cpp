#include "saulproto/host/replay/replay.hpp"

#include <fmt/format.h>
#include <time.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "saulproto/core/saul_can.hpp"

namespace saul::host {
bool can_move_motors(const CanFrame& f) noexcept {
  if (f.error || f.remote) return false;
  if (!f.extended) {
    if (f.id == saulcan::kVelocityCmdId) return true;
    if (f.id == saulcan::kModeCmdId) return f.dlc >= 1 && (f.data[0] == 1 || f.data[0] == 2);
    return false;
  }
  const std::uint32_t command = (f.id >> 8) & 0xFFU;
  return command <= 4 || (command >= 10 && command <= 13);
}

IdMapping parse_id_mapping(std::string_view text) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos || eq == 0 || eq + 1 == text.size())
    throw std::invalid_argument(fmt::format("bad id mapping '{}': use FROM=TO in hex, e.g. 300=310", text));
  IdMapping m;
  m.from = parse_can_id(text.substr(0, eq), text, m.from_extended);
  m.to = parse_can_id(text.substr(eq + 1), text, m.to_extended);
  return m;
}

ReplayVerdict plan_frame(const CanFrame& in, const ReplayOptions& options, CanFrame& out) {
  if (in.error) return ReplayVerdict::error_frame;
  if (!options.include.empty() && !passes(options.include, in)) return ReplayVerdict::filtered;
  if (!options.exclude.empty() && passes(options.exclude, in)) return ReplayVerdict::filtered;
  out = in;
  out.timestamp_ns.reset();
  for (const auto& m : options.mappings) {
    if (out.id == m.from && out.extended == m.from_extended) {
      out.id = m.to;
      out.extended = m.to_extended;
      break;
    }
  }
  if (!options.allow_motion && can_move_motors(out)) return ReplayVerdict::motion_dropped;
  return ReplayVerdict::send;
}

// ---- pacing -------------------------------------------------------------------------------------------------------

bool ReplayPacer::wait(std::optional<std::uint64_t> timestamp_ns) {
  if (timestamp_ns && last_stamp_) {
    std::uint64_t gap = *timestamp_ns > *last_stamp_ ? *timestamp_ns - *last_stamp_ : 0;
    if (max_gap_ns_ && gap > *max_gap_ns_) gap = *max_gap_ns_;
    t_ += gap;
  }
  if (timestamp_ns) last_stamp_ = timestamp_ns;
  ++pass_items_;
  if (stepping_ || !first_deadline_) {
    anchor_clock_ = clock_.now_ns();
    anchor_t_ = t_;
  }
  std::uint64_t due = anchor_clock_;
  if (speed_ == 1.0) due += t_ - anchor_t_;
  else if (speed_ > 0) due += static_cast<std::uint64_t>(std::llround(static_cast<double>(t_ - anchor_t_) / speed_));
  if (!first_deadline_) first_deadline_ = due;
  if (stepping_ || speed_ <= 0) return true;
  if (!clock_.sleep_until(due)) return false;
  lateness_.add(static_cast<std::int64_t>(clock_.now_ns() - due));
  return true;
}

void ReplayPacer::next_pass() {
  if (pass_items_ > 1) t_ += (t_ - pass_start_t_) / (pass_items_ - 1);  // one mean interval after the last item
  pass_start_t_ = t_;
  pass_items_ = 0;
  last_stamp_.reset();
}

std::uint64_t ReplayPacer::elapsed_ns() const {
  return first_deadline_ && last_sent_ > *first_deadline_ ? last_sent_ - *first_deadline_ : 0;
}

// ---- lateness ---------------------------------------------------------------------------------------------------

std::size_t LatenessStats::bin_of(std::uint64_t ns) {
  if (ns < 1'000'000) return static_cast<std::size_t>(ns / 1'000);
  if (ns < 100'000'000) return kFine + static_cast<std::size_t>((ns - 1'000'000) / 100'000);
  if (ns < 10'000'000'000ULL) return kFine + kMid + static_cast<std::size_t>((ns - 100'000'000) / 10'000'000);
  return kFine + kMid + kCoarse;
}

std::uint64_t LatenessStats::upper_edge(std::size_t bin) {
  if (bin < kFine) return (bin + 1) * 1'000ULL;
  if (bin < kFine + kMid) return 1'000'000ULL + (bin - kFine + 1) * 100'000ULL;
  if (bin < kFine + kMid + kCoarse) return 100'000'000ULL + (bin - kFine - kMid + 1) * 10'000'000ULL;
  return UINT64_MAX;
}

void LatenessStats::add(std::int64_t late_ns) {
  const std::uint64_t v = late_ns > 0 ? static_cast<std::uint64_t>(late_ns) : 0;
  ++bins_[bin_of(v)];
  ++count_;
  if (v > max_) max_ = v;
  if (v > 1'000'000) ++over_1ms_;
}

std::uint64_t LatenessStats::percentile_ns(double p) const {
  if (count_ == 0) return 0;
  auto rank = static_cast<std::uint64_t>(std::ceil(p / 100.0 * static_cast<double>(count_)));
  if (rank < 1) rank = 1;
  if (rank > count_) rank = count_;
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= rank) return std::min(upper_edge(i), max_);
  }
  return max_;
}

// ---- clock --------------------------------------------------------------------------------------------------------

std::uint64_t MonotonicReplayClock::now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
}

bool MonotonicReplayClock::sleep_until(std::uint64_t deadline_ns) {
  for (;;) {
    if (interrupted_ && interrupted_->load()) return false;
    const std::uint64_t now = now_ns();
    if (now >= deadline_ns) return true;
    if (deadline_ns - now > spin_ns_) {
      const std::uint64_t wake = deadline_ns - spin_ns_;
      timespec ts{};
      ts.tv_sec = static_cast<time_t>(wake / 1'000'000'000ULL);
      ts.tv_nsec = static_cast<long>(wake % 1'000'000'000ULL);
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);  // EINTR: loop and look at interrupted_
    }
    // else: spin the last stretch
  }
}

// ---- engine -------------------------------------------------------------------------------------------------------

void replay_passes(ReplayTotals& totals, unsigned loops, ReplayPacer& pacer, const std::function<bool()>& stop,
                   const std::function<void()>& pass) {
  for (unsigned n = 0; (n < loops || n == 0) && !totals.stopped; ++n) {
    totals.stopped = stop && stop();
    if (totals.stopped) break;
    ++totals.passes;
    if (n > 0) pacer.next_pass();
    pass();
  }
  totals.elapsed_ns = pacer.elapsed_ns();
  totals.lateness = pacer.lateness();
}

ReplayReport replay(const std::function<std::unique_ptr<CaptureReader>()>& open_pass, const ReplayOptions& options,
                    ReplayClock& clock, const ReplayHooks& hooks) {
  ReplayReport report;
  ReplayPacer pacer(clock, options, static_cast<bool>(hooks.step));
  replay_passes(report, options.loops, pacer, hooks.stop, [&] {
    auto reader = open_pass();
    read_in_order(reader, {}, [&](const FrameBatch& batch) {
      batch.walk(
          [&](std::size_t i) {
            if (report.stopped) return;
            ++report.frames;
            CanFrame out;
            switch (plan_frame(batch.frames[i], options, out)) {
              case ReplayVerdict::filtered: ++report.filtered; return;
              case ReplayVerdict::motion_dropped: ++report.motion_dropped; return;
              case ReplayVerdict::error_frame: ++report.error_frames; return;
              case ReplayVerdict::send: break;
            }
            report.stopped = (hooks.stop && hooks.stop()) || (hooks.step && !hooks.step(out)) ||
                             !pacer.wait(batch.frames[i].timestamp_ns);
            if (report.stopped) return;
            hooks.send(out);
            ++report.sent;
            pacer.sent();
          },
          [&](const CaptureError& e) {
            if (report.stopped) return;
            ++report.corrupt;
            if (hooks.on_corrupt) hooks.on_corrupt(e);
          });
      return !report.stopped;
    });
  });
  return report;
}

ReplayPreview preview_replay(std::unique_ptr<CaptureReader>& reader, const ReplayOptions& options) {
  ReplayOptions all = options;
  all.allow_motion = true;
  ReplayPreview p;
  read_in_order(reader, {}, [&](const FrameBatch& batch) {
    for (const CanFrame& f : batch.frames) {
      CanFrame out;
      if (plan_frame(f, all, out) != ReplayVerdict::send) continue;
      ++p.to_send;
      if (can_move_motors(out)) ++p.motion;
    }
    return true;
  });
  return p;
}

}  // namespace saul::host
