#include "saulproto/host/report/bus_stats.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/frame_text.hpp"
#include "../capture/read_path.hpp"

namespace saul::host {
namespace {

double seconds(std::uint64_t ns) { return static_cast<double>(ns) / 1e9; }

std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
  std::uint64_t sum;
  return __builtin_add_overflow(a, b, &sum) ? ~std::uint64_t{0} : sum;
}
std::uint64_t saturating_mul(std::uint64_t a, std::uint64_t b) {
  std::uint64_t product;
  return __builtin_mul_overflow(a, b, &product) ? ~std::uint64_t{0} : product;
}

/// Gaps of this id longer than this are counted (0: none): 0x300 against the BALANCE board's Orin timeout.
std::uint64_t timeout_of(const BusStats::IdKey& id) {
  return !id.first && id.second == saulcan::kVelocityCmdId ? kOrinTimeoutNs : 0;
}

std::string duration_text(double ns) {
  if (ns >= 1e9) return fmt::format("{:.3f} s", ns / 1e9);
  if (ns >= 1e6) return fmt::format("{:.3f} ms", ns / 1e6);
  return fmt::format("{:.1f} us", ns / 1e3);
}

/// The rate, mean gap and longest gap columns of a table ("-" without gaps).
std::string cadence_cells(const Cadence& c) {
  if (c.gaps == 0) return fmt::format("{:>9} {:>11} {:>11}", "-", "-", "-");
  return fmt::format("{:>9.2f} {:>11} {:>11}", c.rate_hz(), duration_text(c.mean_gap_ns()),
                     duration_text(static_cast<double>(c.max_gap_ns)));
}

/// A stream's count and rate, and its gaps' mean and longest when it has gaps.
nlohmann::json cadence_json(const Cadence& c) {
  nlohmann::json j{{"count", c.count}, {"rate_hz", c.rate_hz()}};
  if (c.gaps > 0) {
    j["mean_gap_s"] = c.mean_gap_ns() / 1e9;
    j["max_gap_s"] = seconds(c.max_gap_ns);
  }
  return j;
}

std::string stamp_text(std::uint64_t ns) {
  return fmt::format("{:010}.{:06}", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000);
}

std::string id_text(bool extended, std::uint32_t id) {
  return extended ? fmt::format("{:08X}", id) : fmt::format("{:03X}", id);
}

/// A frame's FrameFacts, its stuff bits already counted (`stuff`: can_stuff_bits(), 0 for an error frame).
FrameFacts facts_of(const CanFrame& f, unsigned stuff) {
  const auto r = decode_bus_name(f);
  return {stuff, r ? Reason::ok : r.reason(), r ? r.value().name : nullptr};
}

/// "serial:/dev/ttyUSB0@460800:8E1" -> 460800 and 11 bits per byte.
void baud_from_link(const std::string& link, std::uint32_t& baud, unsigned& bits) {
  if (!link.starts_with("serial:")) return;
  const auto at = link.rfind('@');
  if (at == std::string::npos) return;
  std::size_t used = 0;
  try {
    baud = static_cast<std::uint32_t>(std::stoul(link.substr(at + 1), &used));
  } catch (...) {
    baud = 0;
    return;
  }
  const std::string format = link.substr(at + 1 + used);
  if (format.size() == 4 && format[0] == ':') {
    const unsigned data = static_cast<unsigned>(format[1] - '0');
    const unsigned parity = format[2] == 'N' ? 0 : 1;
    const unsigned stop = static_cast<unsigned>(format[3] - '0');
    if (data >= 5 && data <= 9 && stop >= 1 && stop <= 2) bits = 1 + data + parity + stop;
  }
}

}  // namespace

unsigned can_frame_bits(const CanFrame& frame, StuffBits stuffing) noexcept {
  if (frame.error) return 0;
  const unsigned n = static_cast<unsigned>(frame.payload().size());
  const unsigned stuffed_region = (frame.extended ? 54U : 34U) + 8 * n;  // SOF .. end of CRC
  const unsigned fixed = (frame.extended ? 67U : 47U) + 8 * n;           // + CRC delimiter, ACK, EOF, IFS
  switch (stuffing) {
    case StuffBits::none: return fixed;
    case StuffBits::worst_case: return fixed + (stuffed_region - 1) / 4;
    case StuffBits::exact: break;
  }
  return fixed + can_stuff_bits(frame);  // table-driven (can_bits.cpp)
}

void Cadence::append(const Cadence& later, std::uint64_t timeout_ns) {
  count += later.count;
  if (!later.first_ns) return;  // no timestamps there: nothing else to add
  if (last_ns) gap_to(*later.first_ns, timeout_ns);  // from the last event here to the first there
  if (later.gaps > 0) {
    if (gaps == 0 || later.max_gap_ns > max_gap_ns) {  // strictly longer: of equal gaps the first stays
      max_gap_ns = later.max_gap_ns;
      max_gap_start_ns = later.max_gap_start_ns;
    }
    gaps += later.gaps;
    gaps_over_timeout += later.gaps_over_timeout;
    back_sum_ns += later.back_sum_ns;
    if (__builtin_add_overflow(gap_square_sum, later.gap_square_sum, &gap_square_sum)) gap_square_sum = ~Sum{0};
  }
  if (!first_ns) first_ns = later.first_ns;
  last_ns = later.last_ns;
}

double Cadence::rate_hz() const {
  if (!first_ns || !last_ns || *last_ns <= *first_ns || gaps == 0) return 0;
  return static_cast<double>(gaps) / seconds(*last_ns - *first_ns);
}

double Cadence::mean_gap_ns() const {
  return gaps > 0 ? static_cast<double>(gap_sum_ns()) / static_cast<double>(gaps) : 0;
}

double Cadence::jitter_ns() const {
  if (gaps < 2) return 0;
  // variance = (n * sum(g^2) - sum(g)^2) / n^2: exact in 128-bit integers for any real capture; in long double when
  // that would overflow.
  const Sum n = gaps;
  const Sum gap_sum = gap_sum_ns();
  Sum n_squares = 0, sum_squared = 0;
  if (!__builtin_mul_overflow(n, gap_square_sum, &n_squares) &&
      !__builtin_mul_overflow(gap_sum, gap_sum, &sum_squared)) {
    const Sum spread = n_squares >= sum_squared ? n_squares - sum_squared : 0;
    return static_cast<double>(std::sqrt(static_cast<long double>(spread)) / static_cast<long double>(n));
  }
  const long double mean = static_cast<long double>(gap_sum) / static_cast<long double>(n);
  const long double variance = static_cast<long double>(gap_square_sum) / static_cast<long double>(n) - mean * mean;
  return variance > 0 ? static_cast<double>(std::sqrt(variance)) : 0;
}

const FrameFacts& FrameFactsCache::get(const CanFrame& f) {
  const FrameKey key = frame_key(f);
  if (entries_.empty()) entries_.resize(kSlots);  // at first use: a BusStats given every frame's facts has none
  Entry& e = entries_[key.slot(kSlots)];
  if (e.used && e.key == key) return e.facts;
  e.used = true;
  e.key = key;
  e.facts = facts_of(f, f.error ? 0 : can_stuff_bits(f));
  return e.facts;
}

inline void BusStats::note_time(std::uint64_t ns) {
  if (!first_ns_ || ns < *first_ns_) first_ns_ = ns;
  if (!last_ns_ || ns > *last_ns_) last_ns_ = ns;
}

BusStats::Content BusStats::content_of(const CanFrame& f, const FrameFacts& facts) {
  const auto none = static_cast<std::uint16_t>(can_frame_bits(f, StuffBits::none));
  return {.id = f.id, .extended = f.extended, .remote = f.remote, .dlc = f.dlc, .reason = facts.reason,
          .bits_none = none,
          .bits_worst = static_cast<std::uint16_t>(can_frame_bits(f, StuffBits::worst_case)),
          .bits_exact = static_cast<std::uint16_t>(none + facts.stuff),  // can_frame_bits(f, StuffBits::exact)
          .name = facts.name, .timeout_ns = timeout_of({f.extended, f.id})};
}

// Inline: the per-frame path of add() and add_known() (stats counts every line through one of them).
inline void BusStats::count(const Content& c, bool timed, std::uint64_t ns, const Known& where) {
  Load& load = *where.load;
  ++load.frames;
  load.bits_none += c.bits_none;
  load.bits_worst += c.bits_worst;
  load.bits_exact += c.bits_exact;
  IdStats& s = *where.id;
  if (timed) {
    if (block_)
      load.timed.push_back({ns, c.bits_worst});  // the windows are worked out by append(), in file order
    else
      add_timed(load, ns, c.bits_worst);
    s.cadence.add_at(ns, c.timeout_ns);
  } else {
    ++s.cadence.count;
  }
  if (c.remote) ++s.remote;
  s.bits_worst = c.bits_worst;
  s.dlc = c.dlc;
  if (c.reason == Reason::ok) {
    if (s.type.empty() || s.type[0] == '!') s.type = c.name;
  } else {
    count_failure(s, c.reason);
  }
}

void BusStats::count_failure(IdStats& s, Reason reason) {
  ++s.decode_errors;
  ++failures_[static_cast<std::uint8_t>(reason)];
  if (s.type.empty()) s.type = std::string("!") + to_string(reason);
}

void BusStats::add(const CanFrame& f, std::string_view interface, const FrameFacts& facts) {
  ++frames_;
  if (f.timestamp_ns) note_time(*f.timestamp_ns);
  if (f.error) {
    ++error_frames_;
    // by class bit (frame_text.hpp), so the table stays small whatever the counters say
    bool any = false;
    for (const auto& c : kErrorClasses)
      if (f.id & c.bit) {
        ++error_kinds_[c.kind];
        any = true;
      }
    if (!any) ++error_kinds_["unspecified"];  // none of the classes' bits
    return;
  }
  count(content_of(f, facts), f.timestamp_ns.has_value(), f.timestamp_ns.value_or(0),
        {serial_, &load_of(interface), &id_of({f.extended, f.id})});
}

void BusStats::add_known(const Content& c, std::string_view interface, std::uint64_t ns, Known& known) {
  if (known.owner != serial_) known = {serial_, &load_of(interface), &id_of({c.extended, c.id})};
  ++frames_;
  note_time(ns);
  count(c, true, ns, known);
}

BusStats::Load& BusStats::load_of(std::string_view interface) {
  if (last_load_ == nullptr || interface != last_interface_) {
    auto it = interfaces_.find(interface);
    if (it == interfaces_.end() && !block_ && interfaces_.size() >= kMaxInterfaces) {
      last_interface_.assign(interface);  // beyond the listed ones: counted, not listed
      last_load_ = unlisted_load_.get();
      return *last_load_;
    }
    if (it == interfaces_.end()) {
      it = interfaces_.emplace(std::string(interface), Load{}).first;
      if (block_) interface_order_.emplace_back(interface);
      if (!spare_timed_.empty()) {  // restart_block() kept it
        it->second.timed = std::move(spare_timed_.back());
        spare_timed_.pop_back();
      }
    }
    last_interface_.assign(interface);
    last_load_ = &it->second;
  }
  return *last_load_;
}

BusStats::IdStats& BusStats::id_of(const IdKey& id) {
  IdSlot& slot = id_slots_[(id.second ^ (id.second >> 6) ^ (id.first ? 0x2A : 0)) % id_slots_.size()];
  if (slot.stats == nullptr || slot.key != id) slot = {id, &listed_or_not(id)};
  return *slot.stats;
}

// A capture lists the ids that came first (kMaxIds, and 0x300 always); block statistics list all theirs.
BusStats::IdStats& BusStats::listed_or_not(const IdKey& id) {
  const auto it = ids_.find(id);
  if (it != ids_.end()) return it->second;
  if (!block_ && ids_.size() >= kMaxIds && id != IdKey{false, saulcan::kVelocityCmdId}) return *unlisted_id_;
  if (block_) id_order_.push_back(id);
  return ids_[id];
}

BusStats::Unlisted BusStats::unlisted_ids() const {
  return {unlisted_id_->cadence.count, unlisted_id_->remote, unlisted_id_->decode_errors};
}

BusStats::Unlisted BusStats::unlisted_interfaces() const { return {unlisted_load_->frames, 0, 0}; }

std::uint64_t BusStats::next_serial() {
  static std::atomic<std::uint64_t> serials{0};
  return ++serials;
}

void BusStats::add_timed(Load& load, std::uint64_t ns, std::uint64_t worst) const {
  if (!load.first_ns) {
    load.first_ns = ns;
    load.window_end_ns = saturating_add(ns, options_.window_ns);
  }
  if (!load.last_ns || ns > *load.last_ns) load.last_ns = ns;
  // Windows of window_ns from the interface's first frame, in file order: a frame at or past the current window's
  // end opens the window it falls in; a frame before it (times can go back) counts in the current one.
  if (ns >= load.window_end_ns) {
    const std::uint64_t index = (ns - *load.first_ns) / options_.window_ns;
    if (index > load.window_index) {
      load.window_index = index;
      load.window_bits = 0;
      load.window_end_ns = saturating_add(*load.first_ns, saturating_mul(index + 1, options_.window_ns));
    }
  }
  load.window_bits += worst;
  if (load.window_bits > load.peak_bits) {
    load.peak_bits = load.window_bits;
    load.peak_index = load.window_index;
  }
}

void BusStats::append_id(IdStats& to, const IdStats& later, std::uint64_t timeout_ns) {
  to.cadence.append(later.cadence, timeout_ns);
  to.remote += later.remote;
  to.decode_errors += later.decode_errors;
  to.bits_worst = later.bits_worst;  // of the last frame, which is there
  to.dlc = later.dlc;
  // the name of the first frame that decoded, else the first failure
  if (to.type.empty() || (to.type[0] == '!' && !later.type.empty() && later.type[0] != '!')) to.type = later.type;
}

void BusStats::restart_block(BusStatsOptions options) {
  assert(block_);
  std::vector<std::vector<Load::Timed>> spare = std::move(spare_timed_);
  for (auto& [name, load] : interfaces_) {
    load.timed.clear();
    spare.push_back(std::move(load.timed));
  }
  *this = BusStats(options, Block{});
  spare_timed_ = std::move(spare);
}

void BusStats::append(const BusStats& later) {
  assert(later.block_ && later.options_.window_ns == options_.window_ns && later.options_.bitrate == options_.bitrate);
  frames_ += later.frames_;
  corrupt_ += later.corrupt_;
  error_frames_ += later.error_frames_;
  if (later.first_ns_ && (!first_ns_ || *later.first_ns_ < *first_ns_)) first_ns_ = later.first_ns_;
  if (later.last_ns_ && (!last_ns_ || *later.last_ns_ > *last_ns_)) last_ns_ = later.last_ns_;
  for (const auto& [kind, count] : later.error_kinds_) error_kinds_[kind] += count;
  for (std::size_t r = 0; r < failures_.size(); ++r) failures_[r] += later.failures_[r];
  for (const std::string& name : later.interface_order_) {  // in file order: the first ones are listed
    const Load& from = later.interfaces_.find(name)->second;
    Load& load = load_of(name);  // beyond the listed ones, *unlisted_load_: only its frames are reported
    load.frames += from.frames;
    load.bits_none += from.bits_none;
    load.bits_worst += from.bits_worst;
    load.bits_exact += from.bits_exact;
    if (block_)
      load.timed.insert(load.timed.end(), from.timed.begin(), from.timed.end());
    else
      for (const Load::Timed& t : from.timed) add_timed(load, t.ns, t.bits);
  }
  unlisted_load_->frames += later.unlisted_load_->frames;  // (a block lists all, so these are 0 there)
  append_id(*unlisted_id_, *later.unlisted_id_, 0);
  for (const IdKey& key : later.id_order_) {  // in file order: the first ones are listed
    IdStats& to = listed_or_not(key);
    append_id(to, later.ids_.find(key)->second, &to == unlisted_id_.get() ? 0 : timeout_of(key));
  }
}

std::uint64_t BusStats::decode_errors() const {
  std::uint64_t n = 0;
  for (const std::uint64_t count : failures_) n += count;
  return n;
}

std::map<std::string, std::uint64_t> BusStats::decode_failures() const {
  std::map<std::string, std::uint64_t> by_name;
  for (std::size_t r = 0; r < failures_.size(); ++r)
    if (failures_[r] > 0) by_name[to_string(static_cast<Reason>(r))] = failures_[r];
  return by_name;
}

double BusStats::load_percent(const Load& load, StuffBits stuffing) const {
  if (!load.first_ns || !load.last_ns || *load.last_ns <= *load.first_ns) return 0;
  const std::uint64_t bits = stuffing == StuffBits::none    ? load.bits_none
                             : stuffing == StuffBits::exact ? load.bits_exact
                                                            : load.bits_worst;
  return 100.0 * static_cast<double>(bits) /
         (seconds(*load.last_ns - *load.first_ns) * static_cast<double>(options_.bitrate));
}

double BusStats::peak_percent(const Load& load) const {
  return 100.0 * static_cast<double>(load.peak_bits) /
         (seconds(options_.window_ns) * static_cast<double>(options_.bitrate));
}

std::string BusStats::text(std::string_view name) const {
  std::string out;
  const double span = first_ns_ && last_ns_ ? static_cast<double>(*last_ns_ - *first_ns_) : 0;
  out += fmt::format("{}: {} frames", name, frames_);
  if (first_ns_)
    out += fmt::format(" from {} to {} ({})", stamp_text(*first_ns_), stamp_text(*last_ns_), duration_text(span));
  out += fmt::format("; {} corrupt records\n", corrupt_);
  for (const auto& [iface, load] : interfaces_) {
    out += fmt::format(
        "bus load on {} at {} kbit/s: {:.2f} % (worst-case stuffing), {:.2f} % (exact), {:.2f} % (no stuffing); "
        "busiest {:g} ms window {:.2f} % at +{:.3f} s\n",
        candump_interface(iface),  // a name from a file: no control character reaches the terminal
        options_.bitrate / 1000, load_percent(load, StuffBits::worst_case), load_percent(load, StuffBits::exact),
        load_percent(load, StuffBits::none), static_cast<double>(options_.window_ns) / 1e6,
        peak_percent(load), seconds(load.peak_index * options_.window_ns));
  }
  if (const Unlisted other = unlisted_interfaces(); other.frames > 0)
    out += fmt::format("{} frames on interfaces beyond the first {} (not listed, no load worked out): more "
                       "interfaces than a bench has; is the log's interface column noise?\n",
                       other.frames, kMaxInterfaces);
  // "3 (2 bus_off, 1 no_ack)"
  auto counted = [](std::uint64_t total, const std::map<std::string, std::uint64_t>& by_kind) {
    std::string kinds;
    for (const auto& [kind, count] : by_kind) kinds += fmt::format("{}{} {}", kinds.empty() ? "" : ", ", count, kind);
    return by_kind.empty() ? fmt::format("{}", total) : fmt::format("{} ({})", total, kinds);
  };
  out += fmt::format("error frames: {}\ndecode errors: {}\n", counted(error_frames_, error_kinds_),
                     counted(decode_errors(), decode_failures()));
  const auto velocity = ids_.find(IdKey{false, saulcan::kVelocityCmdId});
  if (velocity == ids_.end()) {
    out += "0x300 velocity_cmd: none in the capture (the BALANCE board would not drive)\n";
  } else {
    const Cadence& c = velocity->second.cadence;
    const std::uint64_t tail = last_ns_ && c.last_ns ? *last_ns_ - *c.last_ns : 0;
    out += fmt::format("0x300 velocity_cmd: longest silence {}", duration_text(static_cast<double>(c.max_gap_ns)));
    if (c.gaps > 0 && first_ns_) out += fmt::format(" from +{:.3f} s", seconds(c.max_gap_start_ns - *first_ns_));
    out += fmt::format("; {} silences over the 500 ms Orin timeout", c.gaps_over_timeout);
    if (tail > kOrinTimeoutNs) out += fmt::format("; silent for the last {}", duration_text(static_cast<double>(tail)));
    out += '\n';
  }
  out += fmt::format("\n{:<9} {:<20} {:>7} {:>9} {:>11} {:>11} {:>11} {:>10} {:>5} {:>7}\n", "id", "type", "count",
                     "rate/s", "mean gap", "longest gap", "from", "jitter", "bits", "errors");
  for (const auto& [key, s] : ids_) {
    const Cadence& c = s.cadence;
    const std::string from =
        c.gaps > 0 && first_ns_ ? fmt::format("+{:.3f} s", seconds(c.max_gap_start_ns - *first_ns_)) : "-";
    out += fmt::format("{:<9} {:<20} {:>7} {} {:>11} {:>10} {:>5} {:>7}\n", id_text(key.first, key.second), s.type,
                       c.count, cadence_cells(c), from, c.gaps > 1 ? duration_text(c.jitter_ns()) : "-", s.bits_worst,
                       s.decode_errors);
  }
  if (const Unlisted other = unlisted_ids(); other.frames > 0)
    out += fmt::format("... and {} frames ({} remote, {} decode errors) of ids beyond the first {} (not listed): "
                       "more ids than a bus has; noise, or a capture at the wrong bit rate?\n",
                       other.frames, other.remote, other.decode_errors, kMaxIds);
  return out;
}

nlohmann::json BusStats::json(std::string_view name) const {
  nlohmann::json j{{"file", name}, {"kind", "can"}, {"frames", frames_}, {"corrupt", corrupt_},
                   {"bitrate", options_.bitrate}, {"error_frames", error_frames_}, {"error_kinds", error_kinds_},
                   {"decode_errors", decode_errors()}, {"decode_failures", decode_failures()},
                   {"load", nlohmann::json::object()}};
  if (first_ns_) {
    j["first_ns"] = *first_ns_;
    j["last_ns"] = *last_ns_;
    j["duration_s"] = seconds(*last_ns_ - *first_ns_);
  }
  for (const auto& [iface, load] : interfaces_) {
    j["load"][iface] = {{"frames", load.frames},
                    {"bits_worst_case", load.bits_worst},
                    {"bits_exact", load.bits_exact},
                    {"bits_no_stuffing", load.bits_none},
                    {"percent_worst_case", load_percent(load, StuffBits::worst_case)},
                    {"percent_exact", load_percent(load, StuffBits::exact)},
                    {"percent_no_stuffing", load_percent(load, StuffBits::none)},
                    {"peak_window_s", seconds(options_.window_ns)},
                    {"peak_percent_worst_case", peak_percent(load)},
                    {"peak_at_s", seconds(load.peak_index * options_.window_ns)}};
  }
  if (const Unlisted other = unlisted_interfaces(); other.frames > 0)
    j["interfaces_not_listed"] = {{"frames", other.frames}, {"listed_at_most", kMaxInterfaces}};
  nlohmann::json ids = nlohmann::json::array();
  for (const auto& [key, s] : ids_) {
    const Cadence& c = s.cadence;
    nlohmann::json e = cadence_json(c);
    e.update({{"id", key.second},
              {"id_hex", id_text(key.first, key.second)},
              {"extended", key.first},
              {"type", s.type},
              {"remote", s.remote},
              {"decode_errors", s.decode_errors},
              {"bits_worst_case", s.bits_worst}});
    if (c.gaps > 0) {
      e["max_gap_from_s"] = first_ns_ ? seconds(c.max_gap_start_ns - *first_ns_) : 0.0;
      e["jitter_s"] = c.jitter_ns() / 1e9;
    }
    if (!key.first && key.second == saulcan::kVelocityCmdId) {
      e["silences_over_orin_timeout"] = c.gaps_over_timeout;
      if (last_ns_ && c.last_ns) e["silent_at_end_s"] = seconds(*last_ns_ - *c.last_ns);
    }
    ids.push_back(std::move(e));
  }
  j["ids"] = std::move(ids);
  if (const Unlisted other = unlisted_ids(); other.frames > 0)
    j["ids_not_listed"] = {{"frames", other.frames},
                           {"remote", other.remote},
                           {"decode_errors", other.decode_errors},
                           {"listed_at_most", kMaxIds}};
  return j;
}

namespace {

// stats' counter of candump lines of the usual shape, "(SEC.USEC) IFACE ID#DATA", by their text: the head, "IFACE
// ID", in a table of the heads seen (where its frames count), the data in a table of the contents seen (stuff bits
// and decode; first compared with the head's last data). A line costs its time, a lookup or two and a few
// additions. A line of any other shape is refused and read the usual way.
class LineMemo final : public CandumpLineTaker {
 public:
  LineMemo() : heads_(kHeads), contents_(kContents) {}
  /// The lines of the next block go to `stats`.
  void start(BusStats& stats) {
    stats_ = &stats;
    taken_ = 0;
  }
  [[nodiscard]] std::uint64_t taken() const { return taken_; }

  // The loop stats spends its time in: a line's end found in the words read of it anyway, no call per line.
  [[gnu::flatten]] std::size_t take_run(const char* begin, const char* end, std::size_t& used) override {
    const char* p = begin;
    std::size_t n = 0;
    while (end - p > static_cast<std::ptrdiff_t>(kCandumpFixedTimeLength) && *p == '(') {
      Words words;
      std::memcpy(words, p + kCandumpFixedTimeLength, sizeof words);  // kCandumpLineSlack bytes follow `end`
      const auto [length, hash] = detail::first_two(p + kCandumpFixedTimeLength, '\n', '#');  // after the time
      if (length >= sizeof words || length >= static_cast<std::size_t>(end - p) - kCandumpFixedTimeLength) break;
      const std::string_view line(p, kCandumpFixedTimeLength + length);
      std::uint64_t ns = 0;
      if (!times_.read(line, ns) || !count(line, words, hash, ns)) break;
      ++n;
      p += line.size() + 1;
    }
    used = static_cast<std::size_t>(p - begin);
    taken_ += n;
    return n;
  }

 private:
  static constexpr std::size_t kWords = 5;      // the text after the time: 40 bytes at most
  static constexpr std::size_t kHeadWords = 3;  // "IFACE ID": 24 bytes at most
  using Words = std::uint64_t[kWords];  // detail::first_two() looks in all of them

  struct Content {  // 24 bytes
    std::uint64_t text[2]{};  // the data's hex digits, zeros after them
    std::uint32_t tag = 0;    // tag_of(Head::serial, DLC); 0: empty
    std::uint8_t stuff = 0;
    Reason reason = Reason::ok;
    std::uint8_t name = 0;  // in names_
  };
  struct Head {
    std::uint64_t key[kHeadWords]{};  // the text before '#', zeros after it
    std::uint8_t length = 0xFF;       // no head is this long: the slot is empty
    std::uint8_t interface_length = 0;
    bool extended = false;
    std::uint32_t id = 0;
    std::uint32_t serial = 0;  // which head this is, for the contents' table: 1 .. kSerials - 1
    std::uint64_t timeout_ns = 0;
    std::array<std::uint16_t, 9> bits_none{};  // can_frame_bits() by DLC
    std::array<std::uint16_t, 9> bits_worst{};
    std::array<CanStuffStart, 9> stuff_start{};  // by DLC: a new content's stuff bits cost its data bytes only
    BusStats::Known known;
    Content last;  // of this head's last line: most lines repeat their id's last data (no table lookup then)
    MemoJudge table;  // whether this id's new data are worth looking for in the contents' table
  };

  /// Counts the line (time `ns`; `words` from the text after the time; its first '#' at `hash`, 40 when none) from
  /// the tables, filling in what they lack; false for a line of another shape.
  bool count(std::string_view line, const Words& words, std::size_t hash, std::uint64_t ns) {
    const std::size_t length = line.size() - kCandumpFixedTimeLength;
    if (hash > 8 * kHeadWords || hash >= length) return false;
    const std::size_t digits = length - hash - 1;
    if (digits > 16 || digits % 2 != 0) return false;

    std::uint64_t key[kHeadWords];
    for (std::size_t i = 0; i < kHeadWords; ++i) key[i] = detail::first_bytes(words[i], hash > 8 * i ? hash - 8 * i : 0);
    const std::uint64_t h = key[0] * 0x9E3779B97F4A7C15ULL + key[1] * 0xC2B2AE3D27D4EB4FULL +
                            key[2] * 0x165667B19E3779F9ULL;
    Head& head = heads_[h >> (64 - kHeadBits)];  // a product's top bits depend on all of the factor's bits
    if (head.length != hash || ((head.key[0] ^ key[0]) | (head.key[1] ^ key[1]) | (head.key[2] ^ key[2])) != 0) {
      if (!learn(head, line, key, hash)) return false;
    }

    // the data is looked up by its text: its hex digits are read only when it is new
    const char* const data_text = line.data() + kCandumpFixedTimeLength + hash + 1;
    std::uint64_t text[2];
    std::memcpy(text, data_text, sizeof text);  // kCandumpLineSlack bytes follow the line
    text[0] = detail::first_bytes(text[0], digits);
    text[1] = detail::first_bytes(text[1], digits > 8 ? digits - 8 : 0);
    const auto dlc = static_cast<std::uint8_t>(digits / 2);
    // the DLC with the text: "AA" and "AA" and two NULs (a corrupt line, to be refused) are the same text here
    const std::uint32_t tag = tag_of(head, dlc);
    auto same = [&](const Content& c) { return c.tag == tag && ((c.text[0] ^ text[0]) | (c.text[1] ^ text[1])) == 0; };
    if (!same(head.last)) {  // most lines repeat their id's last data: no table lookup then
      if (!head.table.use()) {  // this id's data rarely repeat (a counter, a timestamp)
        if (!learn(head.last, head, dlc, data_text, text)) return false;
      } else {
        const std::uint64_t c = text[0] * 0x9E3779B97F4A7C15ULL + text[1] * 0xC2B2AE3D27D4EB4FULL +
                                std::uint64_t{tag} * 0xD6E8FEB86659FD93ULL;
        Content& slot = contents_[c >> (64 - kContentBits)];
        const bool hit = same(slot);
        if (!hit && !learn(slot, head, dlc, data_text, text)) return false;
        head.last = slot;
        head.table.looked(hit);
      }
    }
    const Content& content = head.last;

    const std::string_view interface(reinterpret_cast<const char*>(head.key), head.interface_length);
    stats_->add_known(content_of(head, content, dlc), interface, ns, head.known);
    return true;
  }

  /// What BusStats counts of a frame of `content` (with `dlc` data bytes) under `head`.
  BusStats::Content content_of(const Head& head, const Content& content, std::uint8_t dlc) const {
    return {.id = head.id, .extended = head.extended, .dlc = dlc, .reason = content.reason,
            .bits_none = head.bits_none[dlc], .bits_worst = head.bits_worst[dlc],
            .bits_exact = static_cast<std::uint16_t>(head.bits_none[dlc] + content.stuff),
            .name = names_[content.name], .timeout_ns = head.timeout_ns};
  }
  /// A head not in the table, "IFACE ID" (`length` bytes, in `key`), from the whole line of the usual shape. (An
  /// interface with '#' gives a shorter head, but no such line is taken: the data after it must be hex digits.)
  bool learn(Head& head, std::string_view line, const std::uint64_t (&key)[kHeadWords], std::size_t length) {
    CanFrame f;
    std::string_view interface;
    if (!parse_candump_usual(line, f, interface)) return false;
    if (serial_ + 1 == kSerials) {  // so many heads learnt: both tables forget them all, so no serial has two heads
      std::fill(heads_.begin(), heads_.end(), Head{});  // `head` among them
      std::fill(contents_.begin(), contents_.end(), Content{});
      serial_ = 0;
    }
    std::memcpy(head.key, key, sizeof head.key);
    head.length = static_cast<std::uint8_t>(length);
    head.interface_length = static_cast<std::uint8_t>(interface.size());  // the interface starts the head
    head.extended = f.extended;
    head.id = f.id;
    head.timeout_ns = timeout_of({f.extended, f.id});
    for (std::uint8_t dlc = 0; dlc <= CanFrame::kMaxDlc; ++dlc) {
      f.dlc = dlc;
      const BusStats::Content c = BusStats::content_of(f, {});
      head.bits_none[dlc] = c.bits_none;
      head.bits_worst[dlc] = c.bits_worst;
      head.stuff_start[dlc] = can_stuff_start(f.id, f.extended, f.remote, dlc);
    }
    head.known = {};
    head.last = {};
    head.table = {};
    head.serial = ++serial_;
    return true;
  }
  /// A content not in the table (`dlc` bytes as hex digits at `data_text`, the key `text`): its stuff bits and
  /// decode, worked out; false when the digits are not hex.
  bool learn(Content& content, const Head& head, std::uint8_t dlc, const char* data_text,
             const std::uint64_t (&text)[2]) {
    std::uint64_t data = 0;
    if (!detail::hex_bytes(data_text, 2U * dlc, data)) return false;
    CanFrame f;
    f.id = head.id;
    f.extended = head.extended;
    f.dlc = dlc;
    std::memcpy(f.data.data(), &data, f.data.size());  // little-endian: the first byte is the lowest
    const FrameFacts facts = facts_of(f, can_stuff_bits(head.stuff_start[dlc], f.data.data()));
    // message names are a few dozen static strings, looked for in names_ unless the head's last content had it
    std::size_t i = head.last.name;
    if (names_[i] != facts.name) {
      i = 0;
      while (i < names_count_ && names_[i] != facts.name) ++i;
      if (i == names_.size()) return false;  // more names than a byte counts: cannot happen, read the usual way
      if (i == names_count_) names_[names_count_++] = facts.name;
    }
    // the slot changes only now: a refused line leaves it as it was
    std::memcpy(content.text, text, sizeof content.text);
    content.tag = tag_of(head, dlc);
    content.stuff = static_cast<std::uint8_t>(facts.stuff);
    content.reason = facts.reason;
    content.name = static_cast<std::uint8_t>(i);
    return true;
  }

  static constexpr std::uint32_t kSerials = std::uint32_t{1} << 24;
  static std::uint32_t tag_of(const Head& head, std::uint8_t dlc) { return head.serial << 8 | dlc; }
  static constexpr unsigned kHeadBits = 8;
  static constexpr std::size_t kHeads = std::size_t{1} << kHeadBits;
  static constexpr unsigned kContentBits = 14;
  static constexpr std::size_t kContents = std::size_t{1} << kContentBits;  // 384 KiB
  std::vector<Head> heads_;
  std::vector<Content> contents_;
  CandumpFixedTimes times_;
  std::array<const char*, 256> names_{};  // names_[0] is nullptr (a frame that did not decode)
  std::size_t names_count_ = 1;
  std::uint32_t serial_ = 0;
  BusStats* stats_ = nullptr;
  std::uint64_t taken_ = 0;
};

}  // namespace

namespace {

/// stats' work on the read path: blocks counted into BusStats blocks of their own (candump lines of the usual shape
/// through LineMemo) and appended in file order; batches read in order added to the stats themselves.
struct StatsWork {
  struct Worker {
    FrameFactsCache facts;  // the bus repeats its frames
    LineMemo lines;
  };
  struct Piece {
    BusStats stats{BusStatsOptions{}, BusStats::Block{}};  // restart_block() gives it the options
    bool block = false;
  };
  BusStats& stats;
  const std::function<void(const CanFrame&)>& also;

  Worker worker() { return Worker{}; }
  bool in_blocks(const CaptureBlocks*) { return !also; }  // `also` sees the frames in order
  void start(Worker& w, Piece& p, bool block) {
    p.block = block;
    if (!block) return;
    p.stats.restart_block(stats.options());
    w.lines.start(p.stats);
  }
  CandumpLineTaker* taker(Worker& w) { return &w.lines; }
  void add(Worker& w, Piece& p, const FrameBatch& batch) {
    BusStats& to = p.block ? p.stats : stats;
    const std::size_t n = batch.frames.size();
    for (std::size_t i = 0; i < n; ++i) {
      const CanFrame& f = batch.frames[i];
      to.add(f, batch.interfaces[i], w.facts.get(f));
      if (also) also(f);
    }
  }
  std::uint64_t finish(Worker& w, Piece& p) { return p.block ? w.lines.taken() : 0; }
  void take(Piece& p) {
    if (p.block) stats.append(p.stats);
  }
};

}  // namespace

void add_capture(BusStats& stats, const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                 const ReadOptions& options, const std::function<void(const CaptureError&)>& on_corrupt,
                 const std::function<void(std::uint64_t records, std::uint64_t bytes)>& on_progress,
                 const std::function<void(const CanFrame&)>& also) {
  StatsWork work{stats, also};
  detail::read_capture(path, reader, compressed, options, work,
                       {[&](const CaptureError& e) {
                          stats.add_corrupt();
                          if (on_corrupt) on_corrupt(e);
                        },
                        on_progress});
}

// ---- serial -----------------------------------------------------------------------------------------------------

void SerialStats::add(const SerialChunk& chunk) {
  auto it = links_.find(chunk.link);
  if (it == links_.end() && links_.size() >= SerialCaptureDecoder::kMaxLinks) {
    decoder_.add(chunk, {});  // counts it among the links it does not decode (the same first ones as here)
    return;
  }
  if (it == links_.end()) {
    it = links_.emplace(chunk.link, Link{}).first;
    baud_from_link(chunk.link, it->second.baud, it->second.bits_per_byte);
  }
  it->second.chunks.add(chunk.timestamp_ns);
  it->second.bytes += chunk.bytes.size();
  decoder_.add(chunk, [this](const SerialChunk& c, SerialProtocol, const SerialMessage& m) {
    links_[c.link].messages[name_of(m)].add(c.timestamp_ns);
  });
}

void SerialStats::finish() {
  if (finished_) return;
  finished_ = true;
  decoder_.finish([this](const SerialChunk& c, SerialProtocol, const SerialMessage& m) {
    links_[c.link].messages[name_of(m)].add(c.timestamp_ns);
  });
}

std::uint64_t SerialStats::decode_errors() const {
  std::uint64_t n = 0;
  for (const auto& l : decoder_.links()) n += l.counters.errors(l.protocol);
  return n;
}

std::string SerialStats::text(std::string_view name) const {
  std::string out = fmt::format("{}: {} serial links; {} corrupt records\n", name, links_.size(), corrupt_);
  for (const auto& d : decoder_.links()) {
    const auto found = links_.find(d.name);
    if (found == links_.end()) continue;
    const Link& link = found->second;
    const Cadence& c = link.chunks;
    const double span = c.first_ns && c.last_ns ? static_cast<double>(*c.last_ns - *c.first_ns) : 0;
    out += fmt::format("\n{} ({}{}): {} bytes in {} chunks", candump_interface(d.name), to_string(d.protocol),
                       d.guessed ? ", guessed" : "", link.bytes, c.count);
    if (span > 0) {
      const double rate = static_cast<double>(link.bytes) / (span / 1e9);
      out += fmt::format(" over {}, {:.0f} bytes/s", duration_text(span), rate);
      if (link.baud > 0)
        out += fmt::format(", line load {:.2f} % at {} baud ({} bits per byte)",
                           100.0 * rate * link.bits_per_byte / link.baud, link.baud, link.bits_per_byte);
    }
    out += fmt::format("\n  decoder: {}\n", d.counters_text);
    if (link.messages.empty()) continue;
    out += fmt::format("  {:<20} {:>7} {:>9} {:>11} {:>11}\n", "message", "count", "rate/s", "mean gap", "longest gap");
    for (const auto& [type, m] : link.messages)
      out += fmt::format("  {:<20} {:>7} {}\n", type, m.count, cadence_cells(m));
  }
  if (const auto& other = decoder_.unlisted(); other.chunks > 0)
    out += fmt::format("\n{} chunks ({} bytes) on links beyond the first {}: not decoded (more links than a bench "
                       "has; is the capture's link column noise?)\n",
                       other.chunks, other.bytes, SerialCaptureDecoder::kMaxLinks);
  return out;
}

nlohmann::json SerialStats::json(std::string_view name) const {
  nlohmann::json j{{"file", name}, {"kind", "serial"}, {"corrupt", corrupt_}, {"decode_errors", decode_errors()},
                   {"links", nlohmann::json::array()}};
  for (const auto& d : decoder_.links()) {
    const auto found = links_.find(d.name);
    if (found == links_.end()) continue;
    const Link& link = found->second;
    nlohmann::json l{{"link", d.name}, {"protocol", std::string(to_string(d.protocol))},
                     {"protocol_guessed", d.guessed}, {"bytes", link.bytes}, {"chunks", link.chunks.count},
                     {"decoder", d.counters_json}, {"messages", nlohmann::json::object()}};
    if (link.baud) l["baud"] = link.baud;
    for (const auto& [type, m] : link.messages) l["messages"][type] = cadence_json(m);
    j["links"].push_back(std::move(l));
  }
  if (const auto& other = decoder_.unlisted(); other.chunks > 0)
    j["links_not_listed"] = {
        {"chunks", other.chunks}, {"bytes", other.bytes}, {"listed_at_most", SerialCaptureDecoder::kMaxLinks}};
  return j;
}

}  // namespace saul::host
