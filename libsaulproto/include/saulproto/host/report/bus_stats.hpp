// What `saulctl stats` computes over a capture in one pass (memory grows only with the distinct ids, interfaces,
// error kinds and serial links). CAN: per id the count, rate, gaps, jitter, decode failures; error frames by kind;
// bus load with stuff bits worst case (canbusload's default), exact (-e) and none; the busiest window; 0x300
// silences over the Orin timeout. Serial: per link the bytes, line load, the decoder's counters, per message type
// the count, rate and longest gap.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/result.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/report/frame_key.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saul::host {

enum class StuffBits : std::uint8_t {
  none,        ///< no stuff bits at all: the shortest the frame can be
  worst_case,  ///< the most stuff bits any content of this length can need: floor((stuffed bits - 1) / 4)
  exact,       ///< the stuff bits this very frame needs (its id, DLC, data and CRC-15, bit by bit)
};

/// Bits a classic CAN data or remote frame takes on the bus, from SOF to the end of the 3-bit intermission:
/// 47 + 8n (11-bit id) or 67 + 8n (29-bit id) bits without stuffing, n the data bytes (0 for a remote frame),
/// plus stuff bits over SOF..CRC (34 + 8n or 54 + 8n bits). Error frames are not on the wire as frames: 0.
unsigned can_frame_bits(const CanFrame& frame, StuffBits stuffing) noexcept;
/// The stuff bits the transmitter inserts in a data or remote frame, from SOF to the end of the CRC-15.
unsigned can_stuff_bits(const CanFrame& frame) noexcept;
/// What a frame's id, flags and DLC decide of its stuff bits (the header stuffed and put through the CRC), kept per
/// id and DLC by stats' line tables.
struct CanStuffStart {
  std::uint16_t crc = 0;    ///< the CRC-15 register after the header and then `bytes` zero bytes
  std::uint8_t state = 0;   ///< the stuffing machine after the header: no bit yet (0), else run length and last bit
  std::uint8_t stuff = 0;   ///< stuff bits in the header
  std::uint8_t bytes = 0;   ///< data bytes that follow (0 for a remote frame)
};
CanStuffStart can_stuff_start(std::uint32_t id, bool extended, bool remote, std::uint8_t dlc) noexcept;
/// can_stuff_bits() of the frame whose header gave `start` and whose data is start.bytes bytes at `data`.
unsigned can_stuff_bits(const CanStuffStart& start, const std::uint8_t* data) noexcept;

/// The BALANCE board stops driving when no 0x300 came for this long.
inline constexpr std::uint64_t kOrinTimeoutNs = 500'000'000ULL;

/// Timing of a stream of events (frames of one id, messages of one type), in constant memory. The gaps are summed
/// as integers, so that append() of consecutive parts (stats' blocks, on several threads) gives exactly one pass.
struct Cadence {
  __extension__ typedef unsigned __int128 Sum;
  std::uint64_t count = 0;
  std::optional<std::uint64_t> first_ns;
  std::optional<std::uint64_t> last_ns;
  std::uint64_t gaps = 0;            ///< gaps measured (events with a timestamp after the first)
  std::uint64_t max_gap_ns = 0;      ///< the longest gap; of equal ones, the first
  std::uint64_t max_gap_start_ns = 0;  ///< when the longest gap began (the event before it)
  std::uint64_t gaps_over_timeout = 0;  ///< gaps longer than the timeout given to add()
  Sum back_sum_ns = 0;               ///< how far the times went back, summed (such a step's gap counts as 0)
  Sum gap_square_sum = 0;            ///< sum of the gaps' squares (ns^2; held at its maximum rather than wrapping)
  /// The sum of the gaps max(0, t[i] - t[i-1]): last - first, plus the steps back (summed as they come).
  [[nodiscard]] Sum gap_sum_ns() const noexcept {
    return first_ns ? Sum{*last_ns} - Sum{*first_ns} + back_sum_ns : 0;  // >= 0: the wrap of Sum cancels
  }
  /// One event at `ns` (or without a time): the gap from the event before counts when both have times.
  void add(std::optional<std::uint64_t> ns, std::uint64_t timeout_ns = 0) {
    if (ns)
      add_at(*ns, timeout_ns);
    else
      ++count;
  }
  /// The same for an event with a time (stats' per-frame path).
  void add_at(std::uint64_t ns, std::uint64_t timeout_ns = 0) {
    ++count;
    if (last_ns)
      gap_to(ns, timeout_ns);
    else
      first_ns = ns;  // the first timed event (first_ns and last_ns are set together)
    last_ns = ns;
  }
  /// The events that came right after these ones (the same timeout as their add() calls): afterwards this is
  /// what add() of every event in order would have made.
  void append(const Cadence& later, std::uint64_t timeout_ns = 0);
  [[nodiscard]] double rate_hz() const;        ///< (count - 1) / (last - first); 0 when undefined
  [[nodiscard]] double mean_gap_ns() const;    ///< 0 without gaps
  [[nodiscard]] double jitter_ns() const;      ///< standard deviation of the gaps (population)

 private:
  // Inline: stats adds every timed frame through it.
  void gap_to(std::uint64_t ns, std::uint64_t timeout_ns) {
    std::uint64_t gap = ns - *last_ns;
    if (ns < *last_ns) {  // times went back: no gap (gap_sum_ns())
      back_sum_ns += *last_ns - ns;
      gap = 0;
    }
    ++gaps;
    if (gap > max_gap_ns || gaps == 1) {
      max_gap_ns = gap;
      max_gap_start_ns = *last_ns;
    }
    if (timeout_ns > 0 && gap > timeout_ns) ++gaps_over_timeout;
    const Sum square = Sum{gap} * gap;
    // A square reaches 2^128 only for gaps of centuries (hostile timestamps): hold the sum there, never wrap.
    if (__builtin_add_overflow(gap_square_sum, square, &gap_square_sum)) gap_square_sum = ~Sum{0};
  }
};

struct BusStatsOptions {
  std::uint32_t bitrate = 500'000;
  std::uint64_t window_ns = 100'000'000;  ///< window of the peak load
};

/// What BusStats needs of a frame that depends on its content alone: its exact stuff bits and its decode.
struct FrameFacts {
  unsigned stuff = 0;          ///< can_stuff_bits()
  Reason reason = Reason::ok;  ///< ok: it decoded, as `name`
  const char* name = nullptr;  ///< saul::name_of() of the decoded message
};

/// FrameFacts remembered in a direct-mapped table (a repeated frame costs a lookup). One per thread.
class FrameFactsCache {
 public:
  const FrameFacts& get(const CanFrame& frame);

 private:
  struct Entry {
    FrameKey key;
    bool used = false;
    FrameFacts facts;
  };
  static constexpr std::size_t kSlots = 4096;
  std::vector<Entry> entries_;  // kSlots of them from the first get()
};

/// Statistics of the CAN frames of a capture.
class BusStats {
 public:
  explicit BusStats(BusStatsOptions options = {}) : options_(options), serial_(next_serial()) {}
  /// Statistics of one block of a file, to be append()ed to those of the blocks before it. Its timed frames' time
  /// and bits are kept (16 bytes a frame: memory grows with the block) for append() to work the busiest window out.
  struct Block {};
  BusStats(BusStatsOptions options, Block) : options_(options), block_(true), serial_(next_serial()) {}
  BusStats(const BusStats&) = delete;  // it keeps pointers into its own maps
  BusStats& operator=(const BusStats&) = delete;
  BusStats(BusStats&&) = default;  // map nodes stay put when a map moves
  BusStats& operator=(BusStats&&) = default;
  /// One frame (error frames included) seen on `interface`.
  void add(const CanFrame& frame, std::string_view interface) { add(frame, interface, facts_.get(frame)); }
  /// The same with the frame's facts already known (e.g. worked out on another thread).
  void add(const CanFrame& frame, std::string_view interface, const FrameFacts& facts);
  /// Block statistics only: starts again empty for the next block, keeping the timed frames' memory.
  void restart_block(BusStatsOptions options);
  /// One corrupt record of the file.
  void add_corrupt() { ++corrupt_; }
  /// Adds a BusStats(options, Block{}) of the frames right after these (same options): afterwards this holds what
  /// add() of each of them in order would have made. Cost: its ids, interfaces, error kinds and timed frames.
  void append(const BusStats& later);

  struct Load {
    std::uint64_t bits_none = 0;
    std::uint64_t bits_worst = 0;
    std::uint64_t bits_exact = 0;
    std::uint64_t frames = 0;
    std::optional<std::uint64_t> first_ns;
    std::optional<std::uint64_t> last_ns;
    // peak window (worst-case stuffing)
    std::uint64_t window_index = 0;
    std::uint64_t window_bits = 0;
    std::uint64_t peak_bits = 0;
    std::uint64_t peak_index = 0;
    std::uint64_t window_end_ns = 0;  ///< the current window ends here (saturated): a frame before it stays in it
    /// Block statistics only: each timed frame's time and worst-case bits, for append().
    struct Timed {
      std::uint64_t ns;
      std::uint64_t bits;
    };
    std::vector<Timed> timed;
  };
  struct IdStats {
    std::string type;  ///< message name of the first frame that decoded, else "!" + the first failure reason
    Cadence cadence;
    std::uint64_t remote = 0;
    std::uint64_t decode_errors = 0;
    unsigned bits_worst = 0;  ///< of the last frame
    std::uint8_t dlc = 0;     ///< of the last frame
  };
  using IdKey = std::pair<bool, std::uint32_t>;  ///< (extended, id): standard ids sort first
  /// Where add() counts a frame of some interface and id, kept by stats' line memo so that add_known() skips the
  /// lookups (until restart_block(); looked up again after that).
  struct Known {
    std::uint64_t owner = 0;  ///< serial of the BusStats it was looked up in (0: never)
    Load* load = nullptr;
    IdStats* id = nullptr;
  };
  /// All that add() works out of a data or remote frame's content, kept by stats' line memo with the line's text.
  struct Content {
    std::uint32_t id = 0;
    bool extended = false;
    bool remote = false;
    std::uint8_t dlc = 0;
    Reason reason = Reason::ok;  ///< FrameFacts::reason
    std::uint16_t bits_none = 0;   ///< can_frame_bits(frame, StuffBits::none)
    std::uint16_t bits_worst = 0;  ///< ... worst_case
    std::uint16_t bits_exact = 0;  ///< ... exact
    const char* name = nullptr;    ///< FrameFacts::name
    std::uint64_t timeout_ns = 0;  ///< the gap that counts as a silence of this id (0x300: kOrinTimeoutNs), else 0
  };
  /// The Content of a data or remote frame whose FrameFacts are `facts`.
  static Content content_of(const CanFrame& frame, const FrameFacts& facts);
  /// add() of a data or remote frame at `ns` whose content_of() is `content`, through `known` (looked up if stale).
  void add_known(const Content& content, std::string_view interface, std::uint64_t ns, Known& known);

  /// A report lists at most this many ids and interfaces, the first in file order (and 0x300 always), so that a
  /// column of noise takes no memory without end; the others' frames are counted in unlisted_ids() /
  /// unlisted_interfaces(), and everywhere else. Blocks list all theirs; append() applies the limits.
  static constexpr std::size_t kMaxIds = 4096;
  static constexpr std::size_t kMaxInterfaces = 256;
  /// The frames of the ids, or interfaces, beyond the listed ones.
  struct Unlisted {
    std::uint64_t frames = 0;
    std::uint64_t remote = 0;         ///< ids only
    std::uint64_t decode_errors = 0;  ///< ids only
  };
  [[nodiscard]] Unlisted unlisted_ids() const;
  [[nodiscard]] Unlisted unlisted_interfaces() const;

  [[nodiscard]] std::uint64_t frames() const { return frames_; }
  [[nodiscard]] std::uint64_t corrupt() const { return corrupt_; }
  [[nodiscard]] std::uint64_t error_frames() const { return error_frames_; }
  [[nodiscard]] std::uint64_t decode_errors() const;  ///< data/remote frames that did not decode (error frames not)
  [[nodiscard]] const std::map<IdKey, IdStats>& ids() const { return ids_; }
  [[nodiscard]] const std::map<std::string, Load, std::less<>>& interfaces() const { return interfaces_; }
  [[nodiscard]] std::map<std::string, std::uint64_t> decode_failures() const;  ///< reason -> count
  [[nodiscard]] const std::map<std::string, std::uint64_t>& error_kinds() const { return error_kinds_; }
  /// Load of one interface over its span at options().bitrate, in percent; 0 when the span is 0.
  [[nodiscard]] double load_percent(const Load& load, StuffBits stuffing) const;
  [[nodiscard]] double peak_percent(const Load& load) const;
  [[nodiscard]] const BusStatsOptions& options() const { return options_; }
  [[nodiscard]] std::optional<std::uint64_t> first_ns() const { return first_ns_; }
  [[nodiscard]] std::optional<std::uint64_t> last_ns() const { return last_ns_; }

  /// The report, as text and JSON. `name` is the file name shown.
  [[nodiscard]] std::string text(std::string_view name) const;
  [[nodiscard]] nlohmann::json json(std::string_view name) const;

 private:
  /// Puts a frame of `worst` bits at time `ns` into the load's span and busiest window.
  void add_timed(Load& load, std::uint64_t ns, std::uint64_t worst) const;
  static void append_id(IdStats& to, const IdStats& later, std::uint64_t timeout_ns);
  /// The interface's load, made when new (the last one looked up is remembered).
  Load& load_of(std::string_view interface);
  /// The id's statistics, made when new (a small direct-mapped table of the ids looked up); *unlisted_id_ for a new
  /// id beyond kMaxIds.
  IdStats& id_of(const IdKey& id);
  IdStats& listed_or_not(const IdKey& id);
  static std::uint64_t next_serial();
  void note_time(std::uint64_t ns);
  /// What a data or remote frame (at `ns` when `timed`) adds to its interface's load and its id's statistics.
  void count(const Content& content, bool timed, std::uint64_t ns, const Known& where);
  /// count()'s rarer half: a frame that did not decode.
  void count_failure(IdStats& id, Reason reason);

  BusStatsOptions options_;
  bool block_ = false;  // BusStats(options, Block): windows left to append()
  std::uint64_t serial_ = 0;  // Known::owner: different for every BusStats and every restart_block()
  std::vector<std::vector<Load::Timed>> spare_timed_;  // restart_block(): buffers for the next block's interfaces
  std::uint64_t frames_ = 0;
  std::uint64_t corrupt_ = 0;
  std::uint64_t error_frames_ = 0;
  std::optional<std::uint64_t> first_ns_;
  std::optional<std::uint64_t> last_ns_;
  std::map<IdKey, IdStats> ids_;
  std::map<std::string, Load, std::less<>> interfaces_;
  // block statistics: ids and interfaces in the order they came first (append() lists a later block's in file order)
  std::vector<IdKey> id_order_;
  std::vector<std::string> interface_order_;
  // the frames of ids and interfaces beyond kMaxIds / kMaxInterfaces (not a block's), counted as any other
  // (pointers to them are kept, so they do not move with this object)
  std::unique_ptr<IdStats> unlisted_id_ = std::make_unique<IdStats>();
  std::unique_ptr<Load> unlisted_load_ = std::make_unique<Load>();
  std::array<std::uint64_t, 256> failures_{};         // decode failures by Reason (a byte): no name looked up per frame
  std::map<std::string, std::uint64_t> error_kinds_;  // error frame description -> count
  FrameFactsCache facts_;
  // the last interface and ids looked up (map nodes stay put)
  std::string last_interface_;
  Load* last_load_ = nullptr;
  struct IdSlot {
    IdKey key;
    IdStats* stats = nullptr;
  };
  std::array<IdSlot, 64> id_slots_{};
};

/// Adds every frame of `reader` (opened from `path`; `compressed`: gzip or zstd) to `stats` through the one read
/// path, in blocks on options.threads threads or batch by batch: the figures are one thread's. Corrupt records go
/// to add_corrupt() and on_corrupt() in file order. also(frame), when given, sees every frame in file order after
/// its stats.add() (no blocks then). `reader` may be given up for the file's text.
void add_capture(BusStats& stats, const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                 const ReadOptions& options, const std::function<void(const CaptureError&)>& on_corrupt,
                 const std::function<void(std::uint64_t records, std::uint64_t bytes)>& on_progress,
                 const std::function<void(const CanFrame&)>& also = {});

/// Statistics of the serial chunks of a capture: one decoder per link (SerialCaptureDecoder).
class SerialStats {
 public:
  /// `fallback` is the protocol of links whose chunks say raw (else it is guessed).
  explicit SerialStats(std::optional<SerialProtocol> fallback = std::nullopt) : decoder_(fallback) {}
  void add(const SerialChunk& chunk);
  void add_corrupt() { ++corrupt_; }
  /// Ends the decoders; call before reading the results.
  void finish();

  struct Link {
    std::uint32_t baud = 0;       ///< from a "serial:DEV@BAUD:FMT" name, else 0
    unsigned bits_per_byte = 10;  ///< start + data + parity + stop bits
    Cadence chunks;
    std::uint64_t bytes = 0;
    std::map<std::string, Cadence> messages;  ///< by message name
  };
  [[nodiscard]] const std::map<std::string, Link>& links() const { return links_; }
  [[nodiscard]] const SerialCaptureDecoder& decoder() const { return decoder_; }
  [[nodiscard]] std::uint64_t corrupt() const { return corrupt_; }
  [[nodiscard]] std::uint64_t decode_errors() const;
  [[nodiscard]] std::string text(std::string_view name) const;
  [[nodiscard]] nlohmann::json json(std::string_view name) const;

 private:
  SerialCaptureDecoder decoder_;
  std::map<std::string, Link> links_;
  std::uint64_t corrupt_ = 0;
  bool finished_ = false;
};

}  // namespace saul::host
