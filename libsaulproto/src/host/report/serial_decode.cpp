#include "saulproto/host/report/serial_decode.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <exception>

#include "saulproto/host/report/format.hpp"
#include "../util.hpp"

namespace saul::host {
namespace {

/// A protocol's nominal baud rate, for a chunk's time on the wire (10 bits a byte; Pride's 11 are within the idle
/// gap's margin), and its idle gap (idle_gap_ns()).
struct Pace {
  std::uint64_t baud;
  std::uint64_t idle_gap_ns;
};
Pace pace_of(SerialProtocol protocol) {
  switch (protocol) {
    case SerialProtocol::interboard: return {460'800, 1'000'000};  // 9 bytes at 460800 take 0.2 ms
    case SerialProtocol::crsf: return {420'000, 1'748'000};        // Betaflight's CRSF_TIME_NEEDED_PER_FRAME_US
    case SerialProtocol::pride: return {38'400, 1'720'000};        // 6 bytes of 11 bits at 38400 baud
    case SerialProtocol::raw: break;
  }
  return {115'200, UINT64_MAX};
}

}  // namespace

// (interboard and Pride messages through their own overloads, found by argument-dependent lookup)
std::string name_of(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const CrsfMessage& m) -> std::string { return crsf::name_of(m.message); },
                                     [](const CrsfUndecoded& u) { return fmt::format("crsf_0x{:02X}", u.frame.type); },
                                     [](const auto& m) -> std::string { return name_of(m); }},
                    message);
}

SignalValues signal_values(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const CrsfMessage& m) { return signal_values(m.message); },
                                     [](const CrsfUndecoded&) { return SignalValues{}; },
                                     [](const auto& m) { return signal_values(m); }},
                    message);
}

std::string describe(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const CrsfMessage& m) {
                                       // The address after the name, as in the undecoded form below.
                                       std::string text = describe(m.message);
                                       const auto name_end = std::min(text.find(' '), text.size());
                                       text.insert(name_end, fmt::format(" address=0x{:02X}", m.address));
                                       return text;
                                     },
                                     [](const CrsfUndecoded& u) {
                                       return fmt::format("!{} crsf address=0x{:02X} type=0x{:02X} payload={:02X}",
                                                          to_string(u.reason), u.frame.address, u.frame.type,
                                                          fmt::join(u.frame.payload(), ""));
                                     },
                                     [](const auto& m) { return describe(m); }},
                    message);
}

nlohmann::json to_json(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const CrsfMessage& m) {
                                       nlohmann::json j = to_json(m.message);
                                       j["address"] = m.address;
                                       return j;
                                     },
                                     [&message](const CrsfUndecoded& u) {
                                       return nlohmann::json{
                                           {"type", name_of(message)}, {"error", to_string(u.reason)},
                                           {"address", u.frame.address},
                                           {"payload", fmt::format("{:02X}", fmt::join(u.frame.payload(), ""))}};
                                     },
                                     [](const auto& m) { return to_json(m); }},
                    message);
}

bool is_decode_error(const SerialMessage& message) { return std::holds_alternative<CrsfUndecoded>(message); }

std::uint64_t SerialDecodeCounters::errors(SerialProtocol protocol) const noexcept {
  const std::uint64_t common = crc_errors + length_errors + out_of_range + undecoded;
  // CRSF's unknown types are delivered and already counted in undecoded; interboard rejects them.
  return protocol == SerialProtocol::interboard ? common + unknown_types : common;
}

SerialStreamDecoder::SerialStreamDecoder(SerialProtocol protocol) : protocol_(protocol) {
  switch (protocol) {
    case SerialProtocol::interboard: decoder_.emplace<interboard::StreamDecoder>(); break;
    case SerialProtocol::crsf: decoder_.emplace<crsf::StreamDecoder>(); break;
    case SerialProtocol::pride: decoder_.emplace<pride::StreamDecoder>(); break;
    case SerialProtocol::raw: break;
  }
}

/// feed(on_frame) runs the core's noexcept CRSF decoder, each frame to on_message: an exception from on_message is
/// held (the frames after it not delivered) and thrown again once the core has returned, not through it.
template <class Feed>
void SerialStreamDecoder::crsf_frames(const crsf::StreamDecoder& d, Feed&& feed, const Callback& on_message) {
  std::exception_ptr error;
  feed([&](const crsf::Frame& f) noexcept {
    if (error) return;
    try {
      // Every byte before this frame is in an earlier frame or was skipped: the frame ends right after them.
      const std::uint64_t size = f.payload_size + 4U;  // SYNC, LEN, TYPE, payload, CRC
      frame_end_ = std::min<std::uint64_t>(d.counters().bytes_skipped + frame_bytes_ + size, extra_.bytes);
      frame_bytes_ += size;
      const auto r = crsf::decode(f);
      if (r) {
        on_message(SerialMessage(CrsfMessage{f.address, r.value()}));
      } else {
        ++extra_.undecoded;
        on_message(SerialMessage(CrsfUndecoded{f, r.reason()}));
      }
    } catch (...) {
      error = std::current_exception();
    }
  });
  if (error) std::rethrow_exception(error);
}

void SerialStreamDecoder::push(std::span<const std::uint8_t> bytes, const Callback& on_message) {
  // One byte at a time for interboard and Pride, so a message knows the byte that completed it.
  auto per_byte = [&](auto& d) {
    for (std::uint8_t b : bytes) {
      recent_[extra_.bytes % recent_.size()] = b;
      ++extra_.bytes;
      if (auto m = d.push(b)) {
        frame_end_ = extra_.bytes;
        on_message(SerialMessage(*m));
      }
    }
  };
  std::visit(detail::Overload{[&](std::monostate&) { extra_.bytes += bytes.size(); },
                      [&](crsf::StreamDecoder& d) {
                        extra_.bytes += bytes.size();
                        crsf_frames(d, [&](const auto& on_frame) { d.push(bytes, on_frame); }, on_message);
                      },
                      per_byte},  // interboard, Pride
             decoder_);
}

std::size_t SerialStreamDecoder::pending() const {
  return std::visit(detail::Overload{[](const std::monostate&) -> std::size_t { return 0; },
                                     [](const auto& d) -> std::size_t { return d.pending(); }},
                    decoder_);
}

void SerialStreamDecoder::abandon(const Callback& on_message) {
  // interboard and Pride: the core only drops its candidate, so this drops it and pushes its bytes after the
  // first again (they are the last bytes pushed), which is the rescan CRSF's flush() does itself.
  auto rescan = [&](auto& d) {
    while (d.pending() > 0) {
      const std::size_t held = d.pending();
      std::array<std::uint8_t, 64> again{};
      for (std::size_t i = 0; i < held; ++i) again[i] = recent_[(extra_.bytes - held + i) % recent_.size()];
      d.drop_partial();  // counts all `held` as skipped; only the first byte is
      skip_adjust_ += held - 1;
      ++extra_.incomplete;
      for (std::size_t i = 1; i < held; ++i) {
        if (auto m = d.push(again[i])) {
          frame_end_ = extra_.bytes - held + i + 1;
          on_message(SerialMessage(*m));
        }
      }
    }
  };
  std::visit(detail::Overload{[](std::monostate&) {},
                      [&](crsf::StreamDecoder& d) {
                        crsf_frames(d, [&](const auto& on_frame) { d.flush(on_frame); }, on_message);
                      },
                      rescan},  // interboard, Pride
             decoder_);
}

std::uint64_t idle_gap_ns(SerialProtocol protocol) noexcept { return pace_of(protocol).idle_gap_ns; }

void SerialStreamDecoder::note_uart_errors(std::uint8_t errors) {
  if (errors != 0) ++extra_.uart_errors;
}

void SerialStreamDecoder::finish(const Callback& on_message) {
  std::visit(detail::Overload{[](std::monostate&) {},
                      [&](crsf::StreamDecoder&) { abandon(on_message); },  // flushes, as a line gone idle does
                      [&](auto& d) {  // interboard, Pride
                        if (d.pending() > 0) ++extra_.incomplete;
                        d.drop_partial();
                      }},
             decoder_);
}

SerialDecodeCounters SerialStreamDecoder::counters() const {
  SerialDecodeCounters c = extra_;
  std::visit(detail::Overload{[](const std::monostate&) {},
                      [&](const pride::StreamDecoder& d) {
                        const auto& k = d.counters();
                        c.frames = k.frames;
                        c.crc_errors = k.checksum_errors;
                        c.out_of_range = k.out_of_range;
                        c.bytes_skipped = k.bytes_skipped - skip_adjust_;
                      },
                      [&](const auto& d) {  // interboard and CRSF count the same framing errors
                        const auto& k = d.counters();
                        c.frames = k.frames;
                        c.crc_errors = k.crc_errors;
                        c.length_errors = k.length_errors;
                        c.unknown_types = k.unknown_types;
                        c.bytes_skipped = k.bytes_skipped - skip_adjust_;  // (0 for CRSF, which rescans itself)
                        if constexpr (requires { k.incomplete; }) c.incomplete = k.incomplete;  // CRSF's own count
                      }},
             decoder_);
  return c;
}

std::string SerialStreamDecoder::counters_text() const {
  const auto c = counters();
  const std::string uart = c.uart_errors ? fmt::format(", {} uart errors", c.uart_errors) : "";
  switch (protocol_) {
    case SerialProtocol::interboard:
      return fmt::format("{} frames, {} crc errors, {} length errors, {} unknown types, {} bytes skipped, "
                         "{} incomplete{}",
                         c.frames, c.crc_errors, c.length_errors, c.unknown_types, c.bytes_skipped, c.incomplete, uart);
    case SerialProtocol::crsf:
      return fmt::format("{} frames ({} undecoded), {} crc errors, {} length errors, {} bytes skipped, "
                         "{} incomplete{}",
                         c.frames, c.undecoded, c.crc_errors, c.length_errors, c.bytes_skipped, c.incomplete, uart);
    case SerialProtocol::pride:
      return fmt::format("{} frames, {} checksum errors, {} out of range, {} bytes skipped, {} incomplete{}",
                         c.frames, c.crc_errors, c.out_of_range, c.bytes_skipped, c.incomplete, uart);
    case SerialProtocol::raw: break;
  }
  return fmt::format("{} bytes, not decoded (protocol raw){}", c.bytes, uart);
}

nlohmann::json SerialStreamDecoder::counters_json() const {
  const auto c = counters();
  return {{"protocol", std::string(to_string(protocol_))}, {"bytes", c.bytes}, {"frames", c.frames},
          {"crc_errors", c.crc_errors}, {"length_errors", c.length_errors}, {"unknown_types", c.unknown_types},
          {"out_of_range", c.out_of_range}, {"undecoded", c.undecoded}, {"bytes_skipped", c.bytes_skipped},
          {"incomplete", c.incomplete}, {"uart_errors", c.uart_errors}, {"decode_errors", c.errors(protocol_)}};
}

std::optional<SerialProtocol> guess_serial_protocol(std::span<const std::uint8_t> bytes) {
  std::optional<SerialProtocol> best;
  std::uint64_t best_frames = 1;  // at least 2 frames
  for (auto p : {SerialProtocol::interboard, SerialProtocol::crsf, SerialProtocol::pride}) {
    SerialStreamDecoder d(p);
    d.push(bytes, [](const SerialMessage&) {});
    const auto c = d.counters();
    const std::uint64_t good = c.frames - c.undecoded;
    if (good > best_frames && good > c.errors(p)) {
      best = p;
      best_frames = good;
    }
  }
  return best;
}

SerialChunk SerialCaptureDecoder::chunk_of(const State& state, std::uint64_t end) const {
  SerialChunk c;
  c.link = state.name;
  c.protocol = state.decoder->protocol();
  for (const auto& [chunk_end, time] : state.recent) {
    c.timestamp_ns = time;
    if (chunk_end >= end) break;
  }
  return c;
}

void SerialCaptureDecoder::feed(State& state, const SerialChunk& chunk, const Callback& on_message) {
  SerialStreamDecoder& d = *state.decoder;
  d.note_uart_errors(chunk.errors);
  const SerialProtocol protocol = d.protocol();
  if (chunk.timestamp_ns && state.last_ns && d.pending() > 0 && *chunk.timestamp_ns > *state.last_ns) {
    // The chunk's bytes arrived back to back at the end of the gap; before them the line was quiet this long.
    const std::uint64_t on_wire = chunk.bytes.size() * 10'000'000'000ULL / pace_of(protocol).baud;
    const std::uint64_t gap = *chunk.timestamp_ns - *state.last_ns;
    if (gap > on_wire && gap - on_wire > idle_gap_ns(protocol)) {
      SerialStreamDecoder trial = d;
      std::vector<std::pair<std::uint64_t, SerialMessage>> found;
      trial.abandon([&](const SerialMessage& m) { found.emplace_back(trial.frame_end(), m); });
      if (!found.empty()) {  // frames were hiding behind the candidate: it was no frame
        d = std::move(trial);
        for (const auto& [end, m] : found) on_message(chunk_of(state, end), protocol, m);
      }
    }
  }
  if (chunk.timestamp_ns) state.last_ns = chunk.timestamp_ns;
  const std::uint64_t start = d.bytes_pushed();
  state.recent.emplace_back(start + chunk.bytes.size(), chunk.timestamp_ns);
  // Frames are at most 64 bytes and a candidate holds at most 64: older chunks cannot complete one any more.
  while (state.recent.size() > 1 && state.recent[1].first + 128 <= start) state.recent.pop_front();
  d.push(chunk.bytes, [&](const SerialMessage& m) {
    if (d.frame_end() > start) {
      on_message(chunk, protocol, m);
    } else {
      on_message(chunk_of(state, d.frame_end()), protocol, m);
    }
  });
}

void SerialCaptureDecoder::decide(State& state, const Callback& on_message) {
  std::vector<std::uint8_t> bytes;
  bytes.reserve(state.held_bytes);
  for (const auto& c : state.held) bytes.insert(bytes.end(), c.bytes.begin(), c.bytes.end());
  const auto guess = guess_serial_protocol(bytes);
  state.guessed = guess.has_value();
  state.decoder.emplace(guess.value_or(SerialProtocol::raw));
  state.decided = true;
  for (const auto& c : state.held) feed(state, c, on_message);
  state.held.clear();
  state.held.shrink_to_fit();
  state.held_bytes = 0;
}

void SerialCaptureDecoder::add(const SerialChunk& chunk, const Callback& on_message) {
  State* state = nullptr;
  for (auto& s : states_)
    if (s.name == chunk.link) state = &s;
  if (!state && states_.size() >= kMaxLinks) {  // beyond the links decoded: counted only
    ++unlisted_.chunks;
    unlisted_.bytes += chunk.bytes.size();
    return;
  }
  if (!state) {
    state = &states_.emplace_back();
    state->name = chunk.link;
    state->decided = chunk.protocol != SerialProtocol::raw || fallback_;
    if (state->decided)
      state->decoder.emplace(chunk.protocol != SerialProtocol::raw ? chunk.protocol : *fallback_);
  }
  if (state->decided) {
    feed(*state, chunk, on_message);
    return;
  }
  state->held.push_back(chunk);
  state->held_bytes += chunk.bytes.size();
  if (state->held_bytes >= guess_bytes_) decide(*state, on_message);
}

void SerialCaptureDecoder::finish(const Callback& on_message) {
  for (auto& s : states_) {
    if (!s.decided) decide(s, on_message);
    const SerialProtocol protocol = s.decoder->protocol();
    s.decoder->finish([&](const SerialMessage& m) { on_message(chunk_of(s, s.decoder->frame_end()), protocol, m); });
  }
}

std::vector<SerialCaptureDecoder::Link> SerialCaptureDecoder::links() const {
  std::vector<Link> out;
  for (const auto& s : states_) {
    Link l;
    l.name = s.name;
    l.guessed = s.guessed;
    if (s.decoder) {
      l.protocol = s.decoder->protocol();
      l.counters = s.decoder->counters();
      l.counters_text = s.decoder->counters_text();
      l.counters_json = s.decoder->counters_json();
    } else {
      l.counters.bytes = s.held_bytes;
      l.counters_text = fmt::format("{} bytes held, protocol not decided yet", s.held_bytes);
    }
    out.push_back(std::move(l));
  }
  return out;
}

}  // namespace saul::host
