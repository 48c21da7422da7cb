#include "saulproto/host/replay/serial_replay.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/rc_input.hpp"
#include "../util.hpp"

namespace saul::host {
namespace {

// The line settings of each link (docs/protocol.md: inter-board §2, CRSF §7, Pride §8).
constexpr std::uint32_t kInterboardBaud = 460'800;
constexpr std::uint32_t kCrsfBaud = 420'000;

/// An RC_CHANNELS_PACKED frame that asks for estop: CH6 above 1500 us (rc::map_channels evaluates it first).
bool crsf_estop(const crsf::RcChannels& rc) {
  const auto us = crsf::channels_us(rc);
  rc::Channels channels{};
  for (std::size_t i = 0; i < channels.size() && i < us.size(); ++i) channels[i] = us[i];
  return rc::map_channels(channels).estop;
}

/// One link's chunks, held until every byte is decided (in a kept piece or in a motion frame), then handed out in
/// order with the bytes that remain. Shared by the replay and its preview so that both cut alike.
class ChunkCutter {
 public:
  using OnReady = std::function<void(const SerialChunk& chunk, const std::vector<std::uint8_t>& kept)>;

  ChunkCutter(SerialProtocol protocol, bool allow_motion)
      : splitter_(protocol), allow_motion_(allow_motion) {}

  void add(const SerialChunk& chunk, const OnReady& on_ready) {
    held_.push_back(Held{chunk, {}, 0});
    held_.back().kept.reserve(chunk.bytes.size());
    splitter_.push(chunk.bytes, [this](const SerialPiece& p) { apply(p); });
    release(on_ready);
  }
  void finish(const OnReady& on_ready) {
    splitter_.finish([this](const SerialPiece& p) { apply(p); });
    release(on_ready);
  }

  std::uint64_t frames = 0;
  std::uint64_t motion = 0;
  std::uint64_t motion_bytes = 0;
  std::map<std::string, std::uint64_t> motion_by_type;

 private:
  struct Held {
    SerialChunk chunk;
    std::vector<std::uint8_t> kept;
    std::size_t decided = 0;  // bytes of chunk.bytes decided so far
  };

  void apply(const SerialPiece& piece) {
    if (piece.message) ++frames;
    if (piece.motion) {
      ++motion;
      motion_bytes += piece.size;
      ++motion_by_type[name_of(*piece.message)];
    }
    const bool keep = allow_motion_ || !piece.motion;
    std::size_t n = piece.size;
    while (n > 0) {
      if (current_ >= held_.size()) throw std::logic_error("serial replay: a piece beyond the bytes held");
      Held& h = held_[current_];
      const std::size_t room = h.chunk.bytes.size() - h.decided;
      if (room == 0) {
        ++current_;
        continue;
      }
      const std::size_t take = std::min(n, room);
      const auto from = h.chunk.bytes.begin() + static_cast<std::ptrdiff_t>(h.decided);
      if (keep) h.kept.insert(h.kept.end(), from, from + static_cast<std::ptrdiff_t>(take));
      h.decided += take;
      n -= take;
    }
  }

  void release(const OnReady& on_ready) {
    while (!held_.empty() && held_.front().decided == held_.front().chunk.bytes.size()) {
      const Held h = std::move(held_.front());
      held_.pop_front();
      if (current_ > 0) --current_;
      on_ready(h.chunk, h.kept);
    }
  }

  SerialFrameSplitter splitter_;
  bool allow_motion_;
  std::deque<Held> held_;
  std::size_t current_ = 0;  // index in held_ of the first chunk with undecided bytes
};

}  // namespace

// ---- the motion rule ----------------------------------------------------------------------------------------------

bool can_move_motors(const SerialMessage& message) {
  return std::visit(
      detail::Overload{[](const interboard::Message& m) {
                 const auto* rc = std::get_if<interboard::RcCmd>(&m);
                 return rc != nullptr && !rc->kill();
               },
               [](const CrsfMessage& m) {
                 const auto* rc = std::get_if<crsf::RcChannels>(&m.message);
                 return rc != nullptr && !crsf_estop(*rc);
               },
               [](const pride::Message& m) { return std::holds_alternative<pride::VcuCommand>(m); },
               [](const CrsfUndecoded& u) {
                 return u.frame.type == static_cast<std::uint8_t>(crsf::Type::rc_channels_packed);
               }},
      message);
}

// ---- splitter -----------------------------------------------------------------------------------------------------

void SerialFrameSplitter::emit_noise(const Callback& on_piece) {
  if (noise_ == 0) return;
  SerialPiece p;
  p.size = noise_;
  noise_ = 0;
  on_piece(p);
}

void SerialFrameSplitter::push(std::span<const std::uint8_t> bytes, const Callback& on_piece) {
  if (protocol_ == SerialProtocol::raw) {
    noise_ += bytes.size();
    emit_noise(on_piece);
    return;
  }
  held_.insert(held_.end(), bytes.begin(), bytes.end());
  resolve(false, on_piece);
}

void SerialFrameSplitter::finish(const Callback& on_piece) { resolve(true, on_piece); }

// Does a frame start at held_[0]? A fresh decoder of the protocol is fed the held bytes from there on, one at a
// time (and kept across pushes, so no byte is fed twice while the answer is open). The decoders settle every byte
// in stream order, so the first thing they settle is held_[0]: skipped (it is in no frame) or the first byte of the
// frame they deliver, which then ends at the byte just fed.
void SerialFrameSplitter::resolve(bool at_end, const Callback& on_piece) {
  const SerialStreamDecoder::Callback on_message = [this](const SerialMessage& m) {
    if (!found_) found_ = m;
  };
  while (!held_.empty()) {
    if (!probe_) {
      probe_.emplace(protocol_);
      fed_ = 0;
      found_.reset();
    }
    bool skipped = false;  // held_[0] is in no frame
    while (!skipped && !found_ && fed_ < held_.size()) {
      const std::uint8_t b = held_[fed_++];
      probe_->push({&b, 1}, on_message);
      skipped = probe_->counters().bytes_skipped > 0;
    }
    if (skipped || (!found_ && at_end)) {  // (the stream ends inside a frame: its first byte is in no frame either)
      held_.pop_front();                   // the search goes on at the next byte
      ++noise_;
      probe_.reset();
    } else if (found_) {  // a frame from held_[0] to the byte just fed
      emit_noise(on_piece);
      SerialPiece piece;
      piece.size = fed_;
      piece.message = std::move(found_);
      piece.motion = can_move_motors(*piece.message);
      held_.erase(held_.begin(), held_.begin() + static_cast<std::ptrdiff_t>(fed_));
      probe_.reset();
      found_.reset();
      on_piece(piece);
    } else {
      break;  // held_[0] waits for more bytes
    }
  }
  emit_noise(on_piece);
}

// ---- the port -----------------------------------------------------------------------------------------------------

std::optional<SerialSettings> replay_serial_settings(std::string_view captured_link, SerialProtocol protocol) {
  std::optional<SerialSettings> by_protocol;
  switch (protocol) {
    case SerialProtocol::interboard: by_protocol = SerialSettings{kInterboardBaud, 8, Parity::none, 1}; break;
    case SerialProtocol::crsf: by_protocol = SerialSettings{kCrsfBaud, 8, Parity::none, 1}; break;
    case SerialProtocol::pride: by_protocol = SerialSettings{pride::kBaudRate, 8, Parity::even, 1}; break;
    case SerialProtocol::raw: break;
  }
  // A name "serial:DEV@BAUD[:FORMAT]" (as record writes it) states the rate, and maybe the format.
  const auto at = captured_link.find('@');
  if (!captured_link.starts_with("serial:") || at == std::string_view::npos) return by_protocol;
  LinkSpec named;
  try {
    named = parse_link_spec(std::string(captured_link));
  } catch (const std::invalid_argument&) {
    return by_protocol;
  }
  SerialSettings s = captured_link.find(':', at) != std::string_view::npos ? named.serial
                                                                            : by_protocol.value_or(SerialSettings{});
  s.baud = named.serial.baud;
  return s;
}

LinkSpec parse_serial_replay_link(const std::string& text, const std::optional<SerialSettings>& defaults) {
  constexpr std::string_view kScheme = "serial:";
  if (!text.starts_with(kScheme))
    throw std::invalid_argument(
        fmt::format("'{}' is not a serial link: use serial:/dev/ttyUSB0, serial:/dev/ttyUSB0@BAUD or "
                    "serial:/dev/ttyUSB0@BAUD:8E1",
                    text));
  const auto at = text.find('@', kScheme.size());
  std::string full = text;
  if (at == std::string::npos) {
    if (!defaults)
      throw std::invalid_argument(fmt::format(
          "serial link '{}' needs a baud rate (the capture names neither a rate nor a protocol), e.g. {}@460800",
          text, text));
    full = fmt::format("{}@{}:{}", text, defaults->baud, to_string(*defaults));
  } else if (text.find(':', at) == std::string::npos && defaults) {
    full = fmt::format("{}:{}", text, to_string(*defaults));
  }
  return parse_link_spec(full);
}

// ---- engine -------------------------------------------------------------------------------------------------------

SerialReplayReport replay_serial(const std::function<std::unique_ptr<SerialCaptureReader>()>& open_pass,
                                 const SerialReplayOptions& options, ReplayClock& clock,
                                 const SerialReplayHooks& hooks) {
  SerialReplayReport report;
  ReplayPacer pacer(clock, options, static_cast<bool>(hooks.step));
  report.link = options.link;
  bool have_protocol = false;

  const ChunkCutter::OnReady on_ready = [&](const SerialChunk& chunk, const std::vector<std::uint8_t>& kept) {
    if (report.stopped || kept.empty()) return;
    report.stopped = (hooks.stop && hooks.stop()) || (hooks.step && !hooks.step(chunk, kept)) ||
                     !pacer.wait(chunk.timestamp_ns);
    if (report.stopped) return;
    hooks.write(kept);
    ++report.writes;
    report.bytes_sent += kept.size();
    pacer.sent();
  };

  replay_passes(report, options.loops, pacer, hooks.stop, [&] {
    auto reader = open_pass();
    std::optional<ChunkCutter> cutter;
    while (!report.stopped) {
      const auto status = reader->next();
      if (status == SerialCaptureReader::Status::end) break;
      if (status == SerialCaptureReader::Status::corrupt) {
        ++report.corrupt;
        if (hooks.on_corrupt) hooks.on_corrupt(reader->error());
        continue;
      }
      const SerialChunk& chunk = reader->chunk();
      if (report.link.empty()) report.link = chunk.link;
      if (chunk.link != report.link) {
        ++report.other_links;
        continue;
      }
      if (!have_protocol) {
        report.protocol = options.protocol.value_or(chunk.protocol);
        have_protocol = true;
      }
      if (!cutter) cutter.emplace(report.protocol, options.allow_motion);
      ++report.chunks;
      report.bytes += chunk.bytes.size();
      cutter->add(chunk, on_ready);
    }
    if (!cutter) return;
    if (!report.stopped) cutter->finish(on_ready);
    report.frames += cutter->frames;
    if (options.allow_motion) {
      report.motion_sent += cutter->motion;
    } else {
      report.motion_dropped += cutter->motion;
      report.motion_bytes += cutter->motion_bytes;
      for (const auto& [name, n] : cutter->motion_by_type) report.motion_by_type[name] += n;
    }
  });
  return report;
}

// ---- preview ------------------------------------------------------------------------------------------------------

const SerialLinkPreview* SerialReplayPreview::find(std::string_view name) const {
  for (const auto& l : links)
    if (l.name == name) return &l;
  return nullptr;
}

SerialReplayPreview preview_serial_replay(SerialCaptureReader& reader, std::optional<SerialProtocol> fallback) {
  constexpr std::size_t kGuessBytes = 4096;  // as saulctl decode guesses
  struct State {
    SerialLinkPreview p;
    bool decided = false;
    std::vector<SerialChunk> held;  // while guessing
    std::size_t held_bytes = 0;
    std::optional<ChunkCutter> cutter;
  };
  std::vector<State> states;  // few links: a linear search is fine
  SerialReplayPreview preview;

  const auto count_writes = [](State& s) {
    return [&s](const SerialChunk&, const std::vector<std::uint8_t>& kept) {
      if (!kept.empty()) ++s.p.writes;
    };
  };
  auto feed = [&count_writes](State& s, const SerialChunk& chunk) { s.cutter->add(chunk, count_writes(s)); };
  auto decide = [&feed](State& s, SerialProtocol protocol, bool guessed) {
    s.p.protocol = protocol;
    s.p.guessed = guessed;
    s.decided = true;
    s.cutter.emplace(protocol, false);
    for (const auto& c : s.held) feed(s, c);
    s.held.clear();
    s.held.shrink_to_fit();
    s.held_bytes = 0;
  };
  auto guess = [&decide](State& s) {
    std::vector<std::uint8_t> bytes;
    bytes.reserve(s.held_bytes);
    for (const auto& c : s.held) bytes.insert(bytes.end(), c.bytes.begin(), c.bytes.end());
    const auto g = guess_serial_protocol(bytes);
    decide(s, g.value_or(SerialProtocol::raw), g.has_value());
  };

  for (;;) {
    const auto status = reader.next();
    if (status == SerialCaptureReader::Status::end) break;
    if (status == SerialCaptureReader::Status::corrupt) {
      ++preview.corrupt;
      continue;
    }
    const SerialChunk& chunk = reader.chunk();
    auto it = std::find_if(states.begin(), states.end(), [&](const State& s) { return s.p.name == chunk.link; });
    if (it == states.end()) {
      states.emplace_back();
      states.back().p.name = chunk.link;
      it = states.end() - 1;
    }
    State& s = *it;
    ++s.p.chunks;
    s.p.bytes += chunk.bytes.size();
    if (!s.decided) {
      if (chunk.protocol != SerialProtocol::raw || fallback) {
        decide(s, chunk.protocol != SerialProtocol::raw ? chunk.protocol : *fallback, false);
      } else {
        s.held.push_back(chunk);
        s.held_bytes += chunk.bytes.size();
        if (s.held_bytes >= kGuessBytes) guess(s);
        continue;
      }
    }
    feed(s, chunk);
  }
  for (auto& s : states) {
    if (!s.decided) guess(s);
    s.cutter->finish(count_writes(s));
    s.p.frames = s.cutter->frames;
    s.p.motion = s.cutter->motion;
    s.p.motion_bytes = s.cutter->motion_bytes;
    s.p.motion_by_type = s.cutter->motion_by_type;
    preview.links.push_back(std::move(s.p));
  }
  return preview;
}

std::string format_motion_by_type(const std::map<std::string, std::uint64_t>& by_type) {
  std::vector<std::pair<std::string, std::uint64_t>> v(by_type.begin(), by_type.end());
  std::stable_sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  std::string out;
  for (const auto& [name, n] : v) out += fmt::format("{}{} {}", out.empty() ? "" : ", ", name, n);
  return out;
}

}  // namespace saul::host
