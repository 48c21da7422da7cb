// Replaying a CAN capture onto a bus: the scheduling, the id filters and remapping, the motion rule and the lateness
// statistics behind `saulctl replay`, apart from any real clock or link so that tests drive them with a fake clock.
// Timing: every frame gets an absolute deadline on a monotonic clock, from the capture's timestamps (start + file
// time / speed), never from the previous send, so errors do not add up (no drift). Lateness is how long after its
// deadline a frame was handed to the link.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/capture/capture.hpp"

namespace saul::host {

/// Whether a frame sent onto the robot's bus can make a motor move: a 0x300 velocity command, a 0x302 mode
/// command asking for balance (1) or manual (2), or a VESC set command (any 29-bit frame whose command byte, id
/// bits 8..15, is 0..4 or 10..13: duty, current, brake, rpm, position, relative currents and handbrakes).
/// Remote and error frames never. O(1).
bool can_move_motors(const CanFrame& frame) noexcept;

/// "--map 300=310": frames with id `from` go out with id `to`, in the format each side's spelling says.
struct IdMapping {
  std::uint32_t from = 0;
  bool from_extended = false;
  std::uint32_t to = 0;
  bool to_extended = false;
};
/// Parses "300=310", "0x300=0x310", "00000344=00000345". Ids are hex; more than 3 digits or a value above 0x7FF
/// means 29-bit. Throws std::invalid_argument with the accepted form.
IdMapping parse_id_mapping(std::string_view text);

/// How every replay goes, of CAN frames or serial chunks.
struct ReplayPacing {
  double speed = 1.0;                       ///< 2 = twice as fast, 0.5 = half speed, 0 = as fast as possible
  unsigned loops = 1;                       ///< passes over the file
  std::optional<std::uint64_t> max_gap_ns;  ///< longer silences of the file are shortened to this
  bool allow_motion = false;                ///< otherwise what can move motors is dropped
};

struct ReplayOptions : ReplayPacing {
  std::vector<CanFilter> include;   ///< only these logged ids (empty = all)
  std::vector<CanFilter> exclude;   ///< never these logged ids
  std::vector<IdMapping> mappings;  ///< applied after the filters
};

enum class ReplayVerdict : std::uint8_t { send, filtered, motion_dropped, error_frame };

/// What happens to one frame of the file: filters on the logged id, then the id map, then the motion rule (on
/// the frame as it would go out). Error frames are never sent (a link cannot send them). `out` is the frame to
/// send, without timestamp.
ReplayVerdict plan_frame(const CanFrame& in, const ReplayOptions& options, CanFrame& out);

/// Lateness distribution in constant memory: 1 us bins below 1 ms, 100 us bins to 100 ms, 10 ms bins to 10 s,
/// then one bin. Percentiles are the upper edge of the bin holding them (never above the exact maximum).
class LatenessStats {
 public:
  void add(std::int64_t late_ns);  ///< early frames (negative) count as 0
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] std::uint64_t max_ns() const { return max_; }
  [[nodiscard]] std::uint64_t percentile_ns(double p) const;  ///< p in 0..100
  [[nodiscard]] std::uint64_t over_1ms() const { return over_1ms_; }

 private:
  static constexpr std::size_t kFine = 1000, kMid = 990, kCoarse = 990;
  static std::size_t bin_of(std::uint64_t ns);
  static std::uint64_t upper_edge(std::size_t bin);
  std::array<std::uint64_t, kFine + kMid + kCoarse + 1> bins_{};
  std::uint64_t count_ = 0;
  std::uint64_t max_ = 0;
  std::uint64_t over_1ms_ = 0;
};

/// The clock a replay runs on.
class ReplayClock {
 public:
  virtual ~ReplayClock() = default;
  virtual std::uint64_t now_ns() = 0;
  /// Waits until the clock reads deadline_ns or later; false when interrupted first.
  virtual bool sleep_until(std::uint64_t deadline_ns) = 0;
};

/// CLOCK_MONOTONIC. Sleeps with clock_nanosleep(TIMER_ABSTIME) until spin_ns before the deadline, then spins,
/// so a frame leaves within microseconds of its deadline on an idle machine. `interrupted` (Ctrl-C) ends waits.
class MonotonicReplayClock final : public ReplayClock {
 public:
  explicit MonotonicReplayClock(const std::atomic<bool>* interrupted = nullptr, std::uint64_t spin_ns = 200'000)
      : interrupted_(interrupted), spin_ns_(spin_ns) {}
  std::uint64_t now_ns() override;
  bool sleep_until(std::uint64_t deadline_ns) override;

 private:
  const std::atomic<bool>* interrupted_;
  std::uint64_t spin_ns_;
};

/// The timing of one replay, shared by CAN frames and serial chunks. Virtual file time T starts at 0 with the first
/// item and advances by each timestamp gap (negative gaps count as 0, gaps above max_gap as max_gap); a new pass
/// continues one mean item interval of the previous pass after its last item. An item is due at
/// anchor_clock + (T - anchor_T) / speed, anchored at the first item (and, single-stepping, at every item).
class ReplayPacer {
 public:
  ReplayPacer(ReplayClock& clock, const ReplayPacing& pacing, bool stepping)
      : clock_(clock), speed_(pacing.speed), max_gap_ns_(pacing.max_gap_ns), stepping_(stepping) {}
  /// Starts the next pass over the file.
  void next_pass();
  /// Waits until the item logged at timestamp_ns (nullopt: the time of the one before) is due, and records how late
  /// it is (single-stepping or at speed 0: returns at once); false when the wait was interrupted.
  bool wait(std::optional<std::uint64_t> timestamp_ns);
  /// The item went out now.
  void sent() { last_sent_ = clock_.now_ns(); }
  [[nodiscard]] const LatenessStats& lateness() const { return lateness_; }
  /// From the first deadline to the last item sent.
  [[nodiscard]] std::uint64_t elapsed_ns() const;

 private:
  ReplayClock& clock_;
  double speed_;
  std::optional<std::uint64_t> max_gap_ns_;
  bool stepping_;
  std::uint64_t anchor_clock_ = 0;
  std::uint64_t anchor_t_ = 0;
  std::uint64_t t_ = 0;                      // virtual file time of the last item
  std::optional<std::uint64_t> last_stamp_;  // timestamp of the last item of this pass
  std::uint64_t pass_start_t_ = 0;           // virtual file time of the first item of this pass
  std::uint64_t pass_items_ = 0;
  std::optional<std::uint64_t> first_deadline_;
  std::uint64_t last_sent_ = 0;
  LatenessStats lateness_;
};

/// What every replay reports, of CAN frames or serial chunks.
struct ReplayTotals {
  unsigned passes = 0;           ///< passes started
  std::uint64_t elapsed_ns = 0;  ///< from the first deadline to the last send
  bool stopped = false;          ///< ended early (interrupted, or step() said stop)
  LatenessStats lateness;        ///< per item sent; empty in single-step mode and at speed 0
};

/// The passes every replay makes: `loops` of them (at least one), each begun unless `stop` says so (then
/// totals.stopped), `pass()` reading one over `pacer`'s schedule; the pacer's figures end in `totals`.
void replay_passes(ReplayTotals& totals, unsigned loops, ReplayPacer& pacer, const std::function<bool()>& stop,
                   const std::function<void()>& pass);

struct ReplayReport : ReplayTotals {
  std::uint64_t frames = 0;     ///< frames read (all passes)
  std::uint64_t sent = 0;
  std::uint64_t filtered = 0;
  std::uint64_t motion_dropped = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t corrupt = 0;
};

struct ReplayHooks {
  std::function<void(const CanFrame&)> send;  ///< required; exceptions pass through replay()
  /// Single step: called with each frame about to go out; false stops. The schedule is re-anchored after it.
  std::function<bool(const CanFrame&)> step;
  std::function<void(const CaptureError&)> on_corrupt;
  std::function<bool()> stop;  ///< polled before each frame; true ends the replay
};

/// Replays options.loops passes of the capture that open_pass() opens (it is called once per pass).
ReplayReport replay(const std::function<std::unique_ptr<CaptureReader>()>& open_pass, const ReplayOptions& options,
                    ReplayClock& clock, const ReplayHooks& hooks);

/// What a replay would send, from one pass over the file (saulctl says how many motion frames it leaves out).
struct ReplayPreview {
  std::uint64_t to_send = 0;  ///< with motion allowed
  std::uint64_t motion = 0;   ///< of those, frames that can move motors
};
ReplayPreview preview_replay(std::unique_ptr<CaptureReader>& reader, const ReplayOptions& options);

}  // namespace saul::host
