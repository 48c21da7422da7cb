// The message descriptions (core/signals*.hpp) against the typed codecs: every signal of every described message is
// driven through the typed decoder and encoder and through the generic reader, which works from the description
// alone, and the two must agree; frame for frame, values for values, names for names. Then golden frames from
// docs/protocol.md's worked examples, read through the description only.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/core/signals_crsf.hpp"
#include "saulproto/core/signals_interboard.hpp"
#include "saulproto/core/signals_pride.hpp"
#include "saulproto/core/signals_saul.hpp"
#include "saulproto/core/signals_vesc.hpp"

using namespace saul;
using namespace saul::signals;

namespace {

// ---- one field, as the typed struct gives it and as the description reads it -----------------------------------

using FieldValue = std::variant<std::int64_t, double, std::uint32_t /* float32 bits */, std::string>;

struct Field {
  std::string key;
  FieldValue value;
  std::string name;  // an enum's to_string(), or the description's value name for Text::name
  bool operator==(const Field&) const = default;
};

std::string show(const std::vector<Field>& fields) {
  std::string s;
  for (const auto& f : fields) {
    s += " " + f.key + "=";
    std::visit([&s](const auto& v) {
      if constexpr (std::is_same_v<std::decay_t<decltype(v)>, std::string>) s += '"' + v + '"';
      else s += std::to_string(v);
    }, f.value);
    if (!f.name.empty()) s += "(" + f.name + ")";
  }
  return s;
}

template <class M>
std::vector<Field> typed_fields(const M& m) {
  std::vector<Field> out;
  m.fields([&out](const char* key, const auto& v) {
    using T = std::decay_t<decltype(v)>;
    Field f{key, std::int64_t{0}, ""};
    if constexpr (std::is_enum_v<T>) {
      f.value = static_cast<std::int64_t>(v);
      f.name = to_string(v);
    } else if constexpr (std::is_same_v<T, float>) {
      f.value = std::bit_cast<std::uint32_t>(v);
    } else if constexpr (std::is_same_v<T, double>) {
      f.value = v;
    } else if constexpr (std::is_same_v<T, const char*>) {
      f.value = std::string(v);
    } else {
      f.value = static_cast<std::int64_t>(v);
    }
    out.push_back(std::move(f));
  });
  return out;
}

/// A frame of a described message: the CAN id (VESC: with the controller), and the payload.
struct Frame {
  std::uint32_t id = 0;
  std::vector<std::uint8_t> payload;
  bool operator==(const Frame&) const = default;
  [[nodiscard]] Wire wire() const { return Wire{id, payload}; }
};

// What the description says the frame carries: the generic reader only, no codec.
std::vector<Field> described_fields(const MessageDesc& d, const Frame& frame) {
  std::vector<Field> out;
  const Wire w = frame.wire();
  const auto mux = mux_of(d, w);
  for (const auto& s : d.signals) {
    if (!present(s, mux) || s.place == Place::by_header) continue;  // CRSF 0x17's channels: checked on their own
    Field f{s.field, std::int64_t{0}, ""};
    if (s.kind == Kind::string) {
      const auto text = read_string(s, frame.payload);
      REQUIRE(text);
      f.value = std::string(*text);
    } else {
      const auto raw = read(d, s, w);
      REQUIRE(raw);
      switch (s.text) {
        case Text::raw:
          f.value = s.kind == Kind::float32 ? FieldValue{static_cast<std::uint32_t>(*raw)} : FieldValue{*raw};
          break;
        case Text::name:
          f.value = *raw;
          f.name = value_name(s, *raw) != nullptr ? value_name(s, *raw) : "";
          break;
        case Text::physical: f.value = raw_to_physical(s, *raw); break;
        case Text::physical_int: f.value = std::int64_t{std::llround(raw_to_physical(s, *raw))}; break;
      }
    }
    out.push_back(std::move(f));
  }
  return out;
}

// ---- the typed codecs of each protocol, behind one face ------------------------------------------------------------

/// What the typed codec makes of a frame: the reason it refused it, or the fields and what its encoder writes
/// back from them (nullopt: the codec has no encoder for this type).
struct Typed {
  Reason reason = Reason::ok;
  std::vector<Field> fields;
  std::optional<Result<Frame>> encoded;
};

Frame from_can(const CanFrame& f) { return Frame{f.id, {f.payload().begin(), f.payload().end()}}; }

// The payload of a serial frame an encoder wrote: [start][LEN][TYPE] payload [CRC], UART and CRSF alike.
template <std::size_t N>
Result<Frame> serial_payload(const Result<std::size_t>& n, const std::array<std::uint8_t, N>& buf) {
  if (!n) return n.reason();
  return Frame{0, {buf.begin() + 3, buf.begin() + static_cast<std::ptrdiff_t>(n.value() - 1)}};
}

// What a typed decoder gave, and what encode(message) -> optional<Result<Frame>> writes back from it.
template <class Decoded, class Encode>
Typed typed_message(const MessageDesc& d, const Decoded& r, Encode&& encode) {
  if (!r) return {r.reason(), {}, {}};
  Typed t;
  std::visit([&](const auto& m) {
    REQUIRE(std::string(std::decay_t<decltype(m)>::kName) == d.name);
    t.fields = typed_fields(m);
  }, r.value());
  t.encoded = encode(r.value());
  return t;
}

Typed typed_can(const MessageDesc& d, const Frame& frame) {
  CanFrame f;
  f.id = frame.id;
  f.extended = d.protocol == Protocol::vesc_can;
  f.dlc = static_cast<std::uint8_t>(frame.payload.size());
  for (std::size_t i = 0; i < frame.payload.size() && i < 8; ++i) f.data[i] = frame.payload[i];
  return typed_message(d, decode_bus_frame(f), [](const BusMessage& m) {
    return std::optional<Result<Frame>>(from_can(encode_bus_message(m)));
  });
}

Typed typed_interboard(const MessageDesc& d, const Frame& frame) {
  const auto r = interboard::decode_payload(static_cast<std::uint8_t>(d.id), frame.payload);
  return typed_message(d, r, [](const interboard::Message& m) {
    std::array<std::uint8_t, interboard::kMaxFrameSize> buf{};
    return std::optional<Result<Frame>>(serial_payload(interboard::encode(m, buf), buf));
  });
}

// CRSF has encoders for the IO board's telemetry and the RC frame only.
Typed typed_crsf(const MessageDesc& d, const Frame& frame) {
  const auto r = crsf::decode_payload(static_cast<std::uint8_t>(d.id), frame.payload);
  return typed_message(d, r, [](const crsf::Message& message) {
    return std::visit([](const auto& m) -> std::optional<Result<Frame>> {
      if constexpr (requires(std::span<std::uint8_t> out) { crsf::encode(m, out); }) {
        std::array<std::uint8_t, crsf::kMaxFrameSize> buf{};
        return serial_payload(crsf::encode(m, std::span<std::uint8_t>(buf)), buf);
      } else {
        return std::nullopt;
      }
    }, message);
  });
}

// Pride: the payload between the message's header and a checksum made by hand (the manual's ~sum of the bytes).
Typed typed_pride(const MessageDesc& d, const Frame& frame) {
  std::vector<std::uint8_t> bytes{static_cast<std::uint8_t>(d.id >> 8), static_cast<std::uint8_t>(d.id)};
  bytes.insert(bytes.end(), frame.payload.begin(), frame.payload.end());
  std::uint8_t sum = 0;
  for (const auto b : bytes) sum = static_cast<std::uint8_t>(sum + b);
  bytes.push_back(static_cast<std::uint8_t>(~sum));
  return typed_message(d, pride::decode_frame(bytes), [](const pride::Message& m) {
    std::array<std::uint8_t, pride::kFrameSize> buf{};
    const auto n = pride::encode(m, buf);
    if (!n) return std::optional<Result<Frame>>(n.reason());
    return std::optional<Result<Frame>>(Frame{0, {buf.begin() + pride::kHeaderSize, buf.end() - 1}});
  });
}

Typed typed(const MessageDesc& d, const Frame& frame) {
  switch (d.protocol) {
    case Protocol::saul_can:
    case Protocol::vesc_can: return typed_can(d, frame);
    case Protocol::interboard: return typed_interboard(d, frame);
    case Protocol::crsf: return typed_crsf(d, frame);
    case Protocol::pride: return typed_pride(d, frame);
  }
  return {};
}

// ---- frames written from the description ---------------------------------------------------------------------------

/// Writes raw[i] into signal i of d (multiplexed signals only when the multiplexer's raw selects them) and
/// `text` into the message's string. Written with write_raw() only.
Frame pack(const MessageDesc& d, const std::vector<std::int64_t>& raw, const std::string& text = "") {
  Frame f;
  f.payload.assign(d.length, 0);
  if (d.protocol == Protocol::saul_can) f.id = d.id;
  if (d.protocol == Protocol::vesc_can) f.id = d.id << 8;
  std::size_t after = 0;
  for (const auto& s : d.signals)
    if (s.kind == Kind::string) {
      const std::size_t at = s.start_bit / 8u;
      f.payload.resize(d.length + text.size());  // the fixed fields after the string move along with its end
      for (std::size_t i = 0; i < text.size(); ++i) f.payload[at + i] = static_cast<std::uint8_t>(text[i]);
      f.payload[at + text.size()] = 0;
      after = at + text.size() + 1;
    }
  std::optional<std::int64_t> mux;
  for (std::size_t i = 0; i < d.signals.size(); ++i)
    if (d.signals[i].mux == Mux::multiplexer) mux = raw[i];
  for (std::size_t i = 0; i < d.signals.size(); ++i) {
    const auto& s = d.signals[i];
    if (s.kind == Kind::string || !present(s, mux) || s.place == Place::by_header) continue;
    if (s.place == Place::can_id) {
      std::array<std::uint8_t, 4> id{};
      for (unsigned b = 0; b < 4; ++b) id[b] = static_cast<std::uint8_t>(f.id >> (8 * b));
      REQUIRE(write_raw(s, raw[i], id));
      f.id = static_cast<std::uint32_t>(id[0] | (id[1] << 8) | (id[2] << 16) | (id[3] << 24));
    } else {
      REQUIRE(write_raw(s, raw[i], f.payload, s.place == Place::after_string ? after : 0));
    }
  }
  return f;
}

/// A valid value for every signal: 0 where 0 is valid, else the least valid value.
std::vector<std::int64_t> baseline(const MessageDesc& d) {
  std::vector<std::int64_t> raw;
  for (const auto& s : d.signals) raw.push_back(in_valid_range(s, 0) ? 0 : s.min);
  return raw;
}

/// A message's frame with signal i at raw, every other signal valid (and the multiplexer selecting i).
Frame frame_with(const MessageDesc& d, std::size_t i, std::int64_t raw, const std::string& text = "") {
  auto values = baseline(d);
  values[i] = raw;
  const auto& s = d.signals[i];
  if (s.mux == Mux::multiplexed)
    for (std::size_t m = 0; m < d.signals.size(); ++m)
      if (d.signals[m].mux == Mux::multiplexer) values[m] = s.mux_value;
  return pack(d, values, text);
}

std::vector<const MessageDesc*> all_messages() {
  std::vector<const MessageDesc*> out;
  for (const auto p : kProtocols)
    for (const auto& m : messages(p)) out.push_back(&m);
  return out;
}

std::string where(const MessageDesc& d, const SignalDesc& s, std::int64_t raw) {
  return std::string(to_string(d.protocol)) + " " + d.name + "." + s.name + " raw " + std::to_string(raw);
}

/// The values to try for a signal: its valid ends, zero, one past each end where the bits can carry it, random
/// values in the valid range; float32: special and ordinary bit patterns.
std::vector<std::int64_t> values_for(const SignalDesc& s, std::mt19937_64& rng) {
  std::vector<std::int64_t> v;
  if (s.kind == Kind::float32) {
    for (float x : {0.0F, -0.0F, 1.5F, 0.25F, 0.05F, -3.75F, 1e-40F, std::numeric_limits<float>::infinity(),
                    std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::max()})
      v.push_back(std::bit_cast<std::uint32_t>(x));
    for (int i = 0; i < 20; ++i) v.push_back(static_cast<std::uint32_t>(rng()));
    return v;
  }
  v = {s.min, s.max};
  if (in_valid_range(s, 0)) v.push_back(0);
  if (s.min > lowest_raw(s)) v.push_back(s.min - 1);
  if (s.max < highest_raw(s)) v.push_back(s.max + 1);
  v.push_back(lowest_raw(s));
  v.push_back(highest_raw(s));
  std::uniform_int_distribution<std::int64_t> in_range(s.min, s.max);
  for (int i = 0; i < 40; ++i) v.push_back(in_range(rng));
  return v;
}

/// The typed codec and the description on one frame whose signal s holds raw.
void agree(const MessageDesc& d, const SignalDesc& s, std::int64_t raw, const Frame& f) {
  INFO(where(d, s, raw));
  const auto t = typed(d, f);
  const bool outside = !in_valid_range(s, raw);
  if (outside && s.check == Check::decoder) {
    CHECK(t.reason == Reason::out_of_range);
    return;
  }
  INFO("typed codec: " << to_string(t.reason));
  REQUIRE(t.reason == Reason::ok);
  const auto described = described_fields(d, f);
  INFO("typed:    " << show(t.fields));
  INFO("described:" << show(described));
  CHECK(t.fields == described);
  if (!t.encoded) {
    CHECK(s.check != Check::encoder);  // an encoder-enforced range needs an encoder
    return;
  }
  if (outside && s.check == Check::encoder) {
    CHECK(t.encoded->reason() == Reason::out_of_range);
  } else {
    REQUIRE(t.encoded->ok());
    CHECK(t.encoded->value() == f);  // the typed encoder writes exactly the description's bits (and zeros)
    CHECK(read(d, s, t.encoded->value().wire()) == raw);
  }
}

}  // namespace

namespace {
template <class... M, class IdOf>
void check_variant(Protocol p, std::variant<M...>*, IdOf id_of) {
  const auto described = messages(p);
  REQUIRE(described.size() == sizeof...(M));
  std::size_t i = 0;
  auto one = [&]<class T>() {
    const auto& d = described[i++];
    INFO(to_string(p) << " " << T::kName);
    CHECK(std::string(d.name) == T::kName);
    CHECK(d.id == id_of.template operator()<T>());
    CHECK(d.protocol == p);
    CHECK(find(p, d.id) == &d);
    CHECK(find_named(p, T::kName) == &d);
  };
  (one.template operator()<M>(), ...);
}
}  // namespace

TEST_CASE("signals: every message type of every codec is described, by name and id, in the variant's order") {
  check_variant(Protocol::saul_can, static_cast<saulcan::Message*>(nullptr),
                []<class M>() { return static_cast<std::uint32_t>(M::kId); });
  check_variant(Protocol::vesc_can, static_cast<vesc::Message*>(nullptr),
                []<class M>() { return static_cast<std::uint32_t>(M::kCommand); });
  check_variant(Protocol::crsf, static_cast<crsf::Message*>(nullptr),
                []<class M>() { return static_cast<std::uint32_t>(M::kType); });
  check_variant(Protocol::interboard, static_cast<interboard::Message*>(nullptr),
                []<class M>() { return static_cast<std::uint32_t>(M::kType); });
  check_variant(Protocol::pride, static_cast<pride::Message*>(nullptr),
                []<class M>() { return of_pride::id_of(M::kDirection); });
  CHECK(find(Protocol::pride, 0xFE54)->name == std::string("vcu_command"));  // the headers of the manual
  CHECK(find(Protocol::pride, 0x4A01)->name == std::string("controller_status"));
  CHECK(find_can(0x400, false) == find(Protocol::saul_can, 0x400));
  CHECK(find_can(vesc::make_eid(vesc::Command::status_5, 56), true) == find(Protocol::vesc_can, 27));
  CHECK(find_can(0x400, true) == find(Protocol::vesc_can, 4));  // 29-bit 0x400: SET_POS to controller 0
  CHECK(find_can(0x10000 | 0x0900, true) == nullptr);  // id bits 28..16 set: not VESC
  CHECK(find_can(0x304, false) == nullptr);
}

TEST_CASE("signals: every signal, driven through the typed codec and the generic reader, agrees") {
  std::mt19937_64 rng(20240611);
  std::size_t tried = 0;
  for (const auto* d : all_messages()) {
    for (std::size_t i = 0; i < d->signals.size(); ++i) {
      const auto& s = d->signals[i];
      if (s.kind == Kind::string || s.place == Place::by_header) continue;
      for (const auto raw : values_for(s, rng)) {
        const Frame f = frame_with(*d, i, raw);
        // The reader reads back what the writer wrote, in range or not.
        REQUIRE(read(*d, s, f.wire()) == raw);
        agree(*d, s, raw, f);
        ++tried;
      }
    }
  }
  CHECK(tried > 3000);
}

TEST_CASE("signals: every value name is the codec's name for that value") {
  for (const auto* d : all_messages())
    for (std::size_t i = 0; i < d->signals.size(); ++i) {
      const auto& s = d->signals[i];
      if (s.text != Text::name) continue;
      REQUIRE_FALSE(s.values.empty());
      for (const auto& v : s.values) agree(*d, s, v.value, frame_with(*d, i, v.value));  // typed to_string()
    }
  // Named bits and the 0x402 command names against the codec's constants.
  const auto* faults = find_signal(*find(Protocol::saul_can, saulcan::kTelemetryBId), "faults");
  for (unsigned bit = 0; bit < 8; ++bit) CHECK(std::string(value_name(*faults, bit)) == saulcan::fault::bit_name(bit));
  const auto* uart_faults = find_signal(*find(Protocol::interboard, 0x03), "flags");
  CHECK(std::string(value_name(*uart_faults, std::countr_zero(interboard::Fault::kRcLoss))) == "rc_loss");
  CHECK(std::string(value_name(*uart_faults, std::countr_zero(interboard::Fault::kMotorFault))) == "motor_fault");
  CHECK(std::string(value_name(*uart_faults, std::countr_zero(interboard::Fault::kEstop))) == "estop");
  const auto* rc_flags = find_signal(*find(Protocol::interboard, 0x01), "flags");
  CHECK(std::string(value_name(*rc_flags, std::countr_zero(interboard::RcCmd::kArmed))) == "armed");
  CHECK(std::string(value_name(*rc_flags, std::countr_zero(interboard::RcCmd::kKill))) == "kill");
  const auto* command = find_signal(*find(Protocol::saul_can, saulcan::kCommandAckId), "command");
  for (const std::uint32_t id : {saulcan::kPidGainId, saulcan::kModeCmdId, saulcan::kConfigCmdId})
    CHECK(std::string(value_name(*command, id & 0xFF)) == find(Protocol::saul_can, id)->name);
  const auto* uart_state = find_signal(*find(Protocol::interboard, 0x10), "error_state");
  for (unsigned v = 0; v <= 5; ++v)
    CHECK(std::string(value_name(*uart_state, v)) == saulcan::to_string(static_cast<saulcan::RobotState>(v)));
}

TEST_CASE("signals: whole random frames decode the same through the codec and the description") {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> printable(32, 126);
  for (const auto* d : all_messages()) {
    for (int n = 0; n < 300; ++n) {
      std::string text;
      const bool has_text = std::any_of(d->signals.begin(), d->signals.end(),
                                        [](const SignalDesc& s) { return s.kind == Kind::string; });
      if (has_text)
        for (int c = n % 12; c > 0; --c) text += static_cast<char>(printable(rng));
      Frame f = pack(*d, baseline(*d), text);
      for (auto& b : f.payload)
        if (!has_text) b = static_cast<std::uint8_t>(byte(rng));
      if (has_text)  // random bytes everywhere but the string and its NUL
        for (std::size_t i = 0; i < f.payload.size(); ++i) {
          const bool in_text = std::any_of(d->signals.begin(), d->signals.end(), [&](const SignalDesc& s) {
            return s.kind == Kind::string && i >= s.start_bit / 8u && i <= s.start_bit / 8u + text.size();
          });
          if (!in_text) f.payload[i] = static_cast<std::uint8_t>(byte(rng));
        }
      if (d->protocol == Protocol::vesc_can) f.id = d->id << 8 | static_cast<std::uint32_t>(byte(rng));
      // The description's verdict: a decoder-checked signal outside its range means out_of_range.
      bool valid = true;
      const auto mux = mux_of(*d, f.wire());
      for (const auto& s : d->signals)
        if (s.kind != Kind::string && s.check == Check::decoder && present(s, mux))
          valid = valid && in_valid_range(s, *read(*d, s, f.wire()));
      const auto t = typed(*d, f);
      INFO(d->name << " frame " << n);
      if (!valid) {
        CHECK(t.reason == Reason::out_of_range);
        continue;
      }
      INFO("typed codec: " << to_string(t.reason));
      REQUIRE(t.reason == Reason::ok);
      CHECK(t.fields == described_fields(*d, f));
    }
  }
}

TEST_CASE("signals: payload lengths: CAN and UART exact, CRSF a minimum with longer payloads read the same") {
  for (const auto* d : all_messages()) {
    INFO(d->name);
    const Frame f = pack(*d, baseline(*d));
    for (const auto& s : d->signals)  // every signal within the length (reserved bytes may follow the last)
      if (s.kind != Kind::string && s.place == Place::payload) CHECK(signals::detail::bytes_needed(s) <= d->length);
    Frame shorter = f;
    shorter.payload.pop_back();
    CHECK_FALSE(typed(*d, shorter).reason == Reason::ok);
    Frame longer = f;
    longer.payload.push_back(0x5A);
    const auto t = typed(*d, longer);
    if (d->exact_length) {  // a length check, whatever the signals reach
      CHECK(t.reason != Reason::ok);
      continue;
    }
    // A minimum length is where the signals end: a shorter payload leaves one (or the string) unreadable.
    bool all_read = true;
    const auto mux = mux_of(*d, shorter.wire());
    for (const auto& s : d->signals)
      if (present(s, mux))
        all_read = all_read && (s.kind == Kind::string ? read_string(s, shorter.payload).has_value()
                                                       : read(*d, s, shorter.wire()).has_value());
    CHECK_FALSE(all_read);
    REQUIRE(t.reason == Reason::ok);
    CHECK(t.fields == described_fields(*d, longer));
  }
}

TEST_CASE("signals: strings (CRSF FLIGHT_MODE, DEVICE_INFO names) and the numbers after them") {
  for (const auto type : {crsf::Type::flight_mode, crsf::Type::device_info}) {
    const auto* d = find(Protocol::crsf, static_cast<std::uint32_t>(type));
    std::size_t text_index = 0;
    for (std::size_t i = 0; i < d->signals.size(); ++i)
      if (d->signals[i].kind == Kind::string) text_index = i;
    const auto& s = d->signals[text_index];
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{4}, std::size_t{s.length}}) {
      const std::string text(n, 'A');
      INFO(d->name << " with " << n << " characters");
      auto values = baseline(*d);
      for (std::size_t i = 0; i < d->signals.size(); ++i)
        if (d->signals[i].kind != Kind::string) values[i] = 0x11223344 & highest_raw(d->signals[i]);
      const Frame f = pack(*d, values, text);
      const auto t = typed(*d, f);
      REQUIRE(t.reason == Reason::ok);
      CHECK(t.fields == described_fields(*d, f));
      if (t.encoded) CHECK(t.encoded->value() == f);
    }
    // One character more than the codec holds: the codec says truncated, the description finds no NUL.
    const std::string too_long(s.length + 1u, 'B');
    Frame f = pack(*d, baseline(*d), too_long);
    CHECK(typed(*d, f).reason == Reason::truncated);
    CHECK_FALSE(read_string(s, f.payload));
  }
}

TEST_CASE("signals: CRSF channel microseconds: the description's scale truncated is the receivers' formula") {
  const auto& ch1 = of_crsf::kRcChannels[0];
  for (std::int64_t t = 0; t <= crsf::kTicksLimit; ++t) {
    INFO("ticks " << t);
    const auto truncated = static_cast<std::int64_t>(raw_to_physical(ch1, t));
    const std::int64_t receivers = crsf::ticks_to_us(static_cast<std::uint16_t>(t));
    // Below 172 ticks the receivers truncate a negative term toward zero: 1 us more, on some ticks.
    if (t < crsf::kTicksMin) REQUIRE((receivers == truncated || receivers == truncated + 1));
    else REQUIRE(receivers == truncated);
  }
  CHECK(static_cast<int>(raw_to_physical(ch1, crsf::kTicksMid)) == 1500);
}

TEST_CASE("signals: raw_to_physical and physical_to_raw") {
  const auto& pitch = of_saul::kTelemetryA[0];
  CHECK(raw_to_physical(pitch, -1234) == -12.34);
  CHECK(physical_to_raw(pitch, -12.34) == -1234);
  const auto& altitude = of_crsf::kGps[4];
  CHECK(raw_to_physical(altitude, 1034) == 34);
  CHECK(physical_to_raw(altitude, -1000) == 0);
  const auto& rssi = of_crsf::kLinkStatistics[0];
  CHECK(raw_to_physical(rssi, 60) == -60);
  CHECK(physical_to_raw(rssi, -60) == 60);
  const auto& kp = of_saul::kPidGain[2];
  CHECK(raw_to_physical(kp, 0x3FC00000) == 1.5);
  CHECK(physical_to_raw(kp, 1.5) == 0x3FC00000);
  static_assert(raw_to_physical(of_saul::kTelemetryB[2], 39600) == 39.6);  // usable at compile time
}

// ---- golden frames: docs/protocol.md's worked examples, read through the description only ---------------------------

namespace {

Frame bytes(std::uint32_t id, std::initializer_list<std::uint8_t> b) { return Frame{id, b}; }

double physical(const MessageDesc& d, const Frame& f, std::string_view signal) {
  const auto* s = find_signal(d, signal);
  REQUIRE(s != nullptr);
  const auto raw = read(d, *s, f.wire());
  REQUIRE(raw);
  return raw_to_physical(*s, *raw);
}

std::string named(const MessageDesc& d, const Frame& f, std::string_view signal) {
  const auto* s = find_signal(d, signal);
  REQUIRE(s != nullptr);
  const char* n = value_name(*s, *read(d, *s, f.wire()));
  return n != nullptr ? n : "";
}

}  // namespace

TEST_CASE("signals: SAUL golden frames (docs/protocol.md 3)") {
  const auto& a = *find(Protocol::saul_can, 0x400);
  const Frame ta = bytes(0x400, {0x06, 0xFF, 0xA4, 0x01, 0x2C, 0x01, 0x01});  // 400#06FFA4012C0101
  CHECK(physical(a, ta, "pitch") == -2.5);
  CHECK(std::string(find_signal(a, "pitch")->unit) == "deg");
  CHECK(physical(a, ta, "pid_out") == 420);
  CHECK(physical(a, ta, "speed_mmps") == 300);
  CHECK(named(a, ta, "state") == "BALANCE");

  const auto& b = *find(Protocol::saul_can, 0x401);
  const Frame tb = bytes(0x401, {0xB0, 0x04, 0x64, 0xFB, 0xB0, 0x9A, 0x11});  // 401#B00464FBB09A11
  CHECK(physical(b, tb, "vesc_l_rpm") == 1200);
  CHECK(physical(b, tb, "vesc_r_rpm") == -1180);
  CHECK(physical(b, tb, "battery") == 39.6);
  CHECK(std::string(find_signal(b, "battery")->unit) == "V");
  const auto* faults = find_signal(b, "faults");
  CHECK(*read(b, *faults, tb.wire()) == 0x11);  // rc_loss + orin_timeout
  CHECK(std::string(value_name(*faults, 0)) == "rc_loss");
  CHECK(std::string(value_name(*faults, 4)) == "orin_timeout");

  const auto& gain = *find(Protocol::saul_can, 0x301);
  const Frame kd = bytes(0x301, {0x02, 0x07, 0x00, 0x00, 0xCD, 0xCC, 0x4C, 0x3D});  // 301#02070000CDCC4C3D
  CHECK(mux_of(gain, kd.wire()) == 2);
  CHECK(named(gain, kd, "gain") == "kd");
  CHECK(physical(gain, kd, "sequence") == 7);
  CHECK(physical(gain, kd, "kd") == Approx(0.05));
  CHECK_FALSE(present(*find_signal(gain, "kp"), mux_of(gain, kd.wire())));

  const auto& config = *find(Protocol::saul_can, 0x303);
  const Frame cfg = bytes(0x303, {0xD0, 0x07, 0xDC, 0x05});  // 303#D007DC05
  CHECK(physical(config, cfg, "tilt_limit") == 20.0);
  CHECK(physical(config, cfg, "max_speed_mmps") == 1500);

  const auto& ack = *find(Protocol::saul_can, 0x402);
  const Frame ack7 = bytes(0x402, {0x01, 0x07, 0x03});  // 402#010703
  CHECK(named(ack, ack7, "command") == "pid_gain");
  CHECK(physical(ack, ack7, "sequence") == 7);
  CHECK(named(ack, ack7, "result") == "rejected_incomplete");
}

TEST_CASE("signals: VESC golden frames (docs/protocol.md 6)") {
  const auto& s1 = *find(Protocol::vesc_can, 9);
  const Frame st = bytes(0x0938, {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA});  // 00000938#FFFFFB50002300FA
  CHECK(physical(s1, st, "controller_id") == 56);
  CHECK(physical(s1, st, "erpm") == -1200);
  CHECK(physical(s1, st, "current") == 3.5);
  CHECK(physical(s1, st, "duty") == 0.25);
  const auto& s4 = *find(Protocol::vesc_can, 16);
  const Frame st4 = bytes(0x1038, {0x01, 0x60, 0x01, 0x90, 0x00, 0x0C, 0x11, 0x94});  // 00001038#01600190000C1194
  CHECK(physical(s4, st4, "temp_fet") == 35.2);
  CHECK(physical(s4, st4, "temp_motor") == 40.0);
  CHECK(physical(s4, st4, "current_in") == 1.2);
  CHECK(physical(s4, st4, "pid_pos") == 90.0);
  const auto& s5 = *find(Protocol::vesc_can, 27);
  const Frame st5 = bytes(0x1B38, {0x00, 0x01, 0xE2, 0x40, 0x01, 0x6D, 0x00, 0x00});  // 00001B38#0001E240016D0000
  CHECK(physical(s5, st5, "tachometer") == 123456);
  CHECK(physical(s5, st5, "voltage_in") == 36.5);
  const auto& s6 = *find(Protocol::vesc_can, 58);
  const Frame st6 = bytes(0x3A38, {0x04, 0xD2, 0x00, 0x00, 0x0C, 0xE4, 0xFE, 0x0C});  // 00003A38#04D200000CE4FE0C
  CHECK(physical(s6, st6, "adc1") == 1.234);
  CHECK(physical(s6, st6, "adc3") == 3.3);
  CHECK(physical(s6, st6, "ppm") == -0.5);
  const auto& pos = *find(Protocol::vesc_can, 4);
  CHECK(physical(pos, bytes(0x0444, {0x05, 0x5D, 0x4A, 0x80}), "pos") == 90.0);  // 00000444#055D4A80
  const auto& pong = *find(Protocol::vesc_can, 18);
  const Frame pg = bytes(0x1244, {0x38, 0x00});  // 00001244#3800
  CHECK(physical(pong, pg, "controller_id") == 68);
  CHECK(physical(pong, pg, "responder_id") == 56);
  CHECK(named(pong, pg, "hw_type") == "vesc");
}

TEST_CASE("signals: CRSF golden frames (docs/protocol.md 7, T2-T10)") {
  const auto& rc = *find(Protocol::crsf, 0x16);
  const Frame t2{0, {0xAC, 0x98, 0x38, 0xF8, 0x7E, 0x01, 0x70, 0x00, 0xFC, 0x9F, 0xBB, 0xE0,
                     0x03, 0x1F, 0xF8, 0xC0, 0x07, 0x3E, 0xF0, 0x81, 0x0F, 0x7C}};
  const std::int64_t expected[] = {172, 1811, 992, 191, 1792, 0, 2047, 1500, 992, 992, 992, 992, 992, 992, 992, 992};
  for (std::size_t i = 0; i < 16; ++i) CHECK(read(rc, rc.signals[i], t2.wire()) == expected[i]);
  CHECK(static_cast<int>(physical(rc, t2, "ch1")) == 988);
  CHECK(static_cast<int>(physical(rc, t2, "ch2")) == 2012);
  CHECK(static_cast<int>(physical(rc, t2, "ch3")) == 1500);

  const auto& link = *find(Protocol::crsf, 0x14);
  const Frame t3{0, {0x3C, 0x3E, 0x64, 0x09, 0x00, 0x04, 0x03, 0x37, 0x62, 0x08}};
  CHECK(physical(link, t3, "uplink_rssi_1_dbm") == -60);
  CHECK(physical(link, t3, "uplink_rssi_2_dbm") == -62);
  CHECK(physical(link, t3, "uplink_link_quality") == 100);
  CHECK(physical(link, t3, "uplink_snr_db") == 9);
  CHECK(physical(link, t3, "downlink_rssi_dbm") == -55);
  CHECK(physical(link, t3, "downlink_snr_db") == 8);

  const auto& battery = *find(Protocol::crsf, 0x08);
  const Frame t4{0, {0x00, 0xA8, 0x00, 0x7B, 0x00, 0x05, 0xDC, 0x4B}};
  CHECK(physical(battery, t4, "voltage") == 16.8);
  CHECK(physical(battery, t4, "current") == 12.3);
  CHECK(physical(battery, t4, "capacity_mah") == 1500);
  CHECK(physical(battery, t4, "remaining_pct") == 75);

  const auto& attitude = *find(Protocol::crsf, 0x1E);
  const Frame t5{0, {0x03, 0xE8, 0xF8, 0x30, 0x3D, 0x5C}};
  CHECK(physical(attitude, t5, "pitch") == 0.1);
  CHECK(physical(attitude, t5, "roll") == -0.2);
  CHECK(physical(attitude, t5, "yaw") == 1.5708);

  const auto& mode = *find(Protocol::crsf, 0x21);
  CHECK(read_string(mode.signals[0], Frame{0, {0x41, 0x43, 0x52, 0x4F, 0x00}}.payload) == "ACRO");

  const auto& gps = *find(Protocol::crsf, 0x02);
  const Frame t9{0, {0x1F, 0x4D, 0xEA, 0x80, 0x07, 0xFD, 0x70, 0xD0, 0x00, 0x7B, 0x23, 0x28, 0x04, 0x0A, 0x0B}};
  CHECK(physical(gps, t9, "latitude") == 52.52);
  CHECK(physical(gps, t9, "longitude") == 13.405);
  CHECK(physical(gps, t9, "groundspeed") == 12.3);
  CHECK(physical(gps, t9, "heading") == 90.0);
  CHECK(physical(gps, t9, "altitude_m") == 34);
  CHECK(physical(gps, t9, "satellites") == 11);

  const auto& info = *find(Protocol::crsf, 0x29);
  const Frame t10{0, {0xEA, 0xEC, 0x53, 0x41, 0x55, 0x4C, 0x00, 0x45, 0x4C, 0x52, 0x53, 0x00,
                      0x00, 0x00, 0x00, 0x00, 0x03, 0x05, 0x00, 0x00, 0x00}};
  CHECK(physical(info, t10, "destination") == 0xEA);
  CHECK(physical(info, t10, "origin") == 0xEC);
  CHECK(read_string(*find_signal(info, "name"), t10.payload) == "SAUL");
  CHECK(physical(info, t10, "serial_number") == crsf::DeviceInfo::kElrsSerial);
  CHECK(physical(info, t10, "firmware_id") == 0x00030500);
  CHECK(physical(info, t10, "parameters_total") == 0);
}

TEST_CASE("signals: inter-board golden frames (docs/protocol.md 2)") {
  const auto& rc = *find(Protocol::interboard, 0x01);
  const Frame cmd{0, {0xF4, 0x01, 0x06, 0xFF, 0x01}};  // AA 05 01 [F4 01 06 FF 01] 0F
  CHECK(physical(rc, cmd, "throttle") == 500);
  CHECK(physical(rc, cmd, "steer") == -250);
  CHECK(physical(rc, cmd, "flags") == 1);
  const auto& state = *find(Protocol::interboard, 0x10);
  const Frame st{0, {0x2E, 0xFB, 0x2C, 0x01, 0x01}};  // AA 05 10 [2E FB 2C 01 01] 51
  CHECK(physical(state, st, "pitch") == -12.34);
  CHECK(physical(state, st, "pid_out") == 300);
  CHECK(named(state, st, "error_state") == "BALANCE");
  const auto& buzzer = *find(Protocol::interboard, 0x12);
  const Frame bz{0, {0x03, 0xF4, 0x01}};  // AA 03 12 [03 F4 01] 27
  CHECK(physical(buzzer, bz, "tone_id") == 3);
  CHECK(physical(buzzer, bz, "duration_ms") == 500);
}

TEST_CASE("signals: big-endian fields that do not start at a byte boundary follow DBC's sawtooth") {
  // A 12-bit Motorola field whose most significant bit is bit 3 of byte 0: bits 3..0 of byte 0, then byte 1.
  const SignalDesc s = number("x", ByteOrder::big_endian, 3, 12, Kind::unsigned_int);
  const std::uint8_t frame[] = {0xFA, 0xBC};
  CHECK(read_raw(s, frame) == 0xABC);
  std::uint8_t out[2] = {0xF0, 0x00};
  REQUIRE(write_raw(s, 0x123, out));
  CHECK(out[0] == 0xF1);
  CHECK(out[1] == 0x23);
  CHECK(signals::detail::bytes_needed(s) == 2);
  // Little-endian across bytes from bit 5: bits 5..7 of byte 0 are the value's bits 0..2.
  const SignalDesc l = number("y", ByteOrder::little_endian, 5, 6, Kind::signed_int);
  const std::uint8_t le[] = {0b1110'0000, 0b0000'0111};
  CHECK(read_raw(l, le) == -1);
  CHECK_FALSE(read_raw(l, std::span<const std::uint8_t>(le, 1)));
}
