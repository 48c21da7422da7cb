#include "saulproto/host/report/serial_decode.hpp"

#include <fmt/format.h>

#include <type_traits>

#include "saulproto/host/report/format.hpp"
#include "../util.hpp"

namespace saul::host {
namespace {

std::string hex(std::span<const std::uint8_t> bytes) {
  std::string s;
  for (std::uint8_t b : bytes) s += fmt::format("{:02X}", b);
  return s;
}

template <class T>
std::optional<double> number_of(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return static_cast<double>(static_cast<std::underlying_type_t<T>>(v));
  } else if constexpr (std::is_arithmetic_v<T>) {
    return static_cast<double>(v);
  } else {
    return std::nullopt;
  }
}

template <class Variant>
std::optional<double> field_of(const Variant& message, std::string_view field) {
  std::optional<double> found;
  std::visit(
      [&](const auto& m) {
        m.fields([&](const char* name, const auto& value) {
          if (!found && field == name) found = number_of(value);
        });
      },
      message);
  return found;
}

template <class Variant>
std::vector<std::string> names_of(const Variant& message) {
  std::vector<std::string> names;
  std::visit(
      [&](const auto& m) {
        m.fields([&](const char* name, const auto& value) {
          if (number_of(value)) names.emplace_back(name);
        });
      },
      message);
  return names;
}

}  // namespace

std::string name_of(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const interboard::Message& m) -> std::string { return interboard::name_of(m); },
                             [](const crsf::Message& m) -> std::string { return crsf::name_of(m); },
                             [](const pride::Message& m) -> std::string { return pride::name_of(m); },
                             [](const CrsfUndecoded& u) { return fmt::format("crsf_0x{:02X}", u.frame.type); }},
                    message);
}

std::string describe(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const interboard::Message& m) { return describe(m); },
                             [](const crsf::Message& m) { return describe(m); },
                             [](const pride::Message& m) { return describe(m); },
                             [](const CrsfUndecoded& u) {
                               return fmt::format("!{} crsf address=0x{:02X} type=0x{:02X} payload={}",
                                                  to_string(u.reason), u.frame.address, u.frame.type,
                                                  hex(u.frame.payload()));
                             }},
                    message);
}

nlohmann::json to_json(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const interboard::Message& m) { return to_json(m); },
                             [](const crsf::Message& m) { return to_json(m); },
                             [](const pride::Message& m) { return to_json(m); },
                             [&message](const CrsfUndecoded& u) {
                               nlohmann::json j;
                               j["type"] = name_of(message);
                               j["error"] = to_string(u.reason);
                               j["address"] = u.frame.address;
                               j["payload"] = hex(u.frame.payload());
                               return j;
                             }},
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

void SerialStreamDecoder::push(std::span<const std::uint8_t> bytes, const Callback& on_message) {
  extra_.bytes += bytes.size();
  std::visit(detail::Overload{[](std::monostate&) {},
                      [&](interboard::StreamDecoder& d) {
                        d.push(bytes, [&](const interboard::Message& m) { on_message(SerialMessage(m)); });
                      },
                      [&](pride::StreamDecoder& d) {
                        d.push(bytes, [&](const pride::Message& m) { on_message(SerialMessage(m)); });
                      },
                      [&](crsf::StreamDecoder& d) {
                        d.push(bytes, [&](const crsf::Frame& f) {
                          const auto r = crsf::decode(f);
                          if (r) {
                            on_message(SerialMessage(r.value()));
                          } else {
                            ++extra_.undecoded;
                            on_message(SerialMessage(CrsfUndecoded{f, r.reason()}));
                          }
                        });
                      }},
             decoder_);
}

void SerialStreamDecoder::note_uart_errors(std::uint8_t errors) {
  if (errors != 0) ++extra_.uart_errors;
}

void SerialStreamDecoder::finish(const Callback& on_message) {
  std::visit(detail::Overload{[](std::monostate&) {},
                      [&](interboard::StreamDecoder& d) {
                        if (d.pending() > 0) ++extra_.incomplete;
                        d.drop_partial();
                      },
                      [&](pride::StreamDecoder& d) {
                        if (d.pending() > 0) ++extra_.incomplete;
                        d.drop_partial();
                      },
                      [&](crsf::StreamDecoder& d) {
                        d.flush([&](const crsf::Frame& f) {
                          const auto r = crsf::decode(f);
                          if (r) {
                            on_message(SerialMessage(r.value()));
                          } else {
                            ++extra_.undecoded;
                            on_message(SerialMessage(CrsfUndecoded{f, r.reason()}));
                          }
                        });
                      }},
             decoder_);
}

SerialDecodeCounters SerialStreamDecoder::counters() const {
  SerialDecodeCounters c = extra_;
  std::visit(detail::Overload{[](const std::monostate&) {},
                      [&](const interboard::StreamDecoder& d) {
                        const auto& k = d.counters();
                        c.frames = k.frames;
                        c.crc_errors = k.crc_errors;
                        c.length_errors = k.length_errors;
                        c.unknown_types = k.unknown_types;
                        c.bytes_skipped = k.bytes_skipped;
                      },
                      [&](const pride::StreamDecoder& d) {
                        const auto& k = d.counters();
                        c.frames = k.frames;
                        c.crc_errors = k.checksum_errors;
                        c.out_of_range = k.out_of_range;
                        c.bytes_skipped = k.bytes_skipped;
                      },
                      [&](const crsf::StreamDecoder& d) {
                        const auto& k = d.counters();
                        c.frames = k.frames;
                        c.crc_errors = k.crc_errors;
                        c.length_errors = k.length_errors;
                        c.unknown_types = k.unknown_types;
                        c.bytes_skipped = k.bytes_skipped;
                        c.incomplete = k.incomplete;
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
  nlohmann::json j;
  j["protocol"] = std::string(to_string(protocol_));
  j["bytes"] = c.bytes;
  j["frames"] = c.frames;
  j["crc_errors"] = c.crc_errors;
  j["length_errors"] = c.length_errors;
  j["unknown_types"] = c.unknown_types;
  j["out_of_range"] = c.out_of_range;
  j["undecoded"] = c.undecoded;
  j["bytes_skipped"] = c.bytes_skipped;
  j["incomplete"] = c.incomplete;
  j["uart_errors"] = c.uart_errors;
  j["decode_errors"] = c.errors(protocol_);
  return j;
}

std::optional<SerialProtocol> guess_serial_protocol(std::span<const std::uint8_t> bytes) {
  std::optional<SerialProtocol> best;
  std::uint64_t best_frames = 1;  // at least 2 frames
  for (auto p : {SerialProtocol::interboard, SerialProtocol::crsf, SerialProtocol::pride}) {
    SerialStreamDecoder d(p);
    const SerialStreamDecoder::Callback ignore = [](const SerialMessage&) {};
    d.push(bytes, ignore);
    const auto c = d.counters();
    const std::uint64_t good = c.frames - c.undecoded;
    if (good > best_frames && good > c.errors(p)) {
      best = p;
      best_frames = good;
    }
  }
  return best;
}

void SerialCaptureDecoder::feed(State& state, const SerialChunk& chunk, const Callback& on_message) {
  state.decoder->note_uart_errors(chunk.errors);
  if (chunk.timestamp_ns) state.last_ns = chunk.timestamp_ns;
  const SerialProtocol protocol = state.decoder->protocol();
  state.decoder->push(chunk.bytes, [&](const SerialMessage& m) { on_message(chunk, protocol, m); });
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
  if (!state) {
    states_.push_back(State{});
    state = &states_.back();
    state->name = chunk.link;
    const SerialProtocol p = chunk.protocol != SerialProtocol::raw ? chunk.protocol
                                                                   : fallback_.value_or(SerialProtocol::raw);
    if (chunk.protocol != SerialProtocol::raw || fallback_) {
      state->decoder.emplace(p);
      state->decided = true;
    }
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
    SerialChunk last;
    last.link = s.name;
    last.timestamp_ns = s.last_ns;
    s.decoder->finish([&](const SerialMessage& m) { on_message(last, protocol, m); });
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

std::optional<double> numeric_field(const BusMessage& message, std::string_view field) {
  return field_of(message, field);
}

std::optional<double> numeric_field(const SerialMessage& message, std::string_view field) {
  return std::visit(detail::Overload{[&](const interboard::Message& m) { return field_of(m, field); },
                             [&](const crsf::Message& m) { return field_of(m, field); },
                             [&](const pride::Message& m) { return field_of(m, field); },
                             [](const CrsfUndecoded&) -> std::optional<double> { return std::nullopt; }},
                    message);
}

std::vector<std::string> numeric_field_names(const BusMessage& message) { return names_of(message); }

std::vector<std::string> numeric_field_names(const SerialMessage& message) {
  return std::visit(detail::Overload{[](const interboard::Message& m) { return names_of(m); },
                             [](const crsf::Message& m) { return names_of(m); },
                             [](const pride::Message& m) { return names_of(m); },
                             [](const CrsfUndecoded&) { return std::vector<std::string>{}; }},
                    message);
}

}  // namespace saul::host
