#include "saulproto/host/report/mcap_signals.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {
namespace {

using signals::Kind;
using signals::Text;

/// "vesc_status_1" -> "status_1": the topic already says vesc.
std::string_view short_name(const signals::MessageDesc& m) {
  std::string_view name = m.name;
  if (m.protocol == signals::Protocol::vesc_can && name.starts_with("vesc_")) name.remove_prefix(5);
  return name;
}

/// "pitch, deg; wire integer = value x 1/100" and the like: what a viewer shows next to the field.
std::string unit_text(const signals::SignalDesc& s) {
  std::string text = s.name;
  if (s.unit[0] != '\0') text += fmt::format(" in {}", s.unit);
  return text;
}

nlohmann::json property(const signals::SignalDesc& s) {
  nlohmann::json p;
  std::string what = unit_text(s);
  if (s.kind == Kind::string) {
    p["type"] = "string";
  } else if (s.text == Text::name) {
    nlohmann::json names = nlohmann::json::array();
    for (const auto& v : s.values) names.push_back(v.name);
    p["anyOf"] = {{{"enum", names}}, {{"type", "integer"}}};
    what += s.value_bits ? " (a bit's name, or the number)" : " (the value's name, or the number when it has none)";
  } else if (s.text == Text::physical) {
    p["type"] = "number";
  } else if (s.text == Text::physical_int) {
    p["type"] = "integer";
  } else if (s.kind == Kind::float32) {
    p["type"] = "number";
  } else {
    p["type"] = "integer";
    if (signals::text_in_unit(s))
      what = fmt::format("{}: the wire integer, {} x {}/{}{}", raw_key(s), s.name, s.scale_num, s.scale_den,
                         s.unit[0] != '\0' ? fmt::format(" {}", s.unit) : std::string());
  }
  p["description"] = what;
  return p;
}

}  // namespace

std::string mcap_topic(const signals::MessageDesc& message, std::uint32_t controller) {
  if (message.protocol == signals::Protocol::vesc_can) return fmt::format("/vesc/{}/{}", controller, short_name(message));
  return fmt::format("/saul/{}", message.name);
}

std::string mcap_json_schema(const signals::MessageDesc& message, bool with_type) {
  nlohmann::json props = nlohmann::json::object();
  nlohmann::json required = nlohmann::json::array();
  if (with_type) {
    props["type"] = {{"const", message.name}, {"description", "the message's name"}};
    required.push_back("type");
  }
  for (const auto& s : message.signals) {
    if (s.place == signals::Place::can_id) continue;  // the topic's (MessageFormat::mcap_json)
    // a multiplexed signal, or a CRSF subset channel (Place::by_header), is in some messages only
    const bool always = s.mux != signals::Mux::multiplexed && s.place != signals::Place::by_header;
    if (always) required.push_back(s.name);
    if (signals::text_in_unit(s)) {  // the physical value under the name, the wire integer under raw_key()
      const bool whole = signals::text_decimals(s) < 0;
      props[s.name] = {{"type", whole ? "integer" : "number"},
                       {"description", fmt::format("{} in {} (physical value)", s.name, s.unit)}};
      props[raw_key(s)] = property(s);
      if (always) required.push_back(raw_key(s));
    } else {
      props[s.name] = property(s);
    }
  }
  nlohmann::json schema = {{"title", message.name},
                           {"description", fmt::format("{} ({} -> {}), as saulctl decode --json shows it{}",
                                                       message.name, message.sender, message.receiver,
                                                       with_type ? ""
                                                       : message.protocol == signals::Protocol::vesc_can
                                                           ? " without what the topic says (type, controller_id)"
                                                           : " without what the topic says (type)")},
                           {"type", "object"},
                           {"properties", props},
                           {"required", required},
                           {"additionalProperties", false}};
  return schema.dump();
}

std::uint16_t mcap_channel_id(const signals::MessageDesc& message, std::uint32_t controller) {
  const auto place = static_cast<std::uint16_t>(&message - signals::messages(message.protocol).data());
  if (message.protocol == signals::Protocol::vesc_can)
    return static_cast<std::uint16_t>(256 * (1 + place) + (controller & 0xFF));
  return static_cast<std::uint16_t>(1 + place);
}

void McapSignalChannels::on_frame(const CanFrame& frame, std::uint64_t log_time, std::string_view interface_json,
                                  McapChunk& chunk) {
  const FrameKey key = frame_key(frame);
  const std::size_t at = key.slot(kCache);
  Rendered& slot = cache_[at];
  if (keys_[at] != key) {
    keys_[at] = key;
    render(frame, slot);
  }
  const std::string_view text = slot.text;
  add_frame_message(chunk, kMcapFramesChannel, text.substr(0, slot.head), log_time, interface_json);
  if (slot.decoded) chunk.add_message(slot.channel, log_time, text.substr(slot.head));
}

void McapSignalChannels::render(const CanFrame& frame, Rendered& slot) {
  std::array<char, kMcapFrameHeadMax> head;
  slot.head = static_cast<std::size_t>(mcap_frame_json_head(frame, head.data()) - head.data());
  slot.text.assign(head.data(), slot.head);
  slot.decoded = false;
  if (frame.error || frame.remote) return;
  const signals::MessageDesc* d = signals::find_can(frame.id, frame.extended);
  if (d == nullptr || !decode_bus_frame(frame)) return;  // rejected: on /can/frames only
  slot.channel = mcap_channel_id(*d, d->protocol == signals::Protocol::vesc_can ? (frame.id & 0xFF) : 0);
  append_message(slot.text, MessageFormat::mcap_json, *d, signals::Wire{frame.id, frame.payload()});
  slot.decoded = true;
}

bool McapSignalChannels::declare(McapWriter& out, std::uint16_t channel_id) {
  const auto saul = signals::messages(signals::Protocol::saul_can);
  const auto vesc = signals::messages(signals::Protocol::vesc_can);
  const signals::MessageDesc* d = nullptr;
  std::uint32_t controller = 0, can_id = 0;
  std::uint16_t schema = 0;
  if (channel_id >= 1 && channel_id <= saul.size()) {
    d = &saul[channel_id - 1u];
    can_id = d->id;
    schema = static_cast<std::uint16_t>(1 + channel_id);
  } else if (const std::size_t place = channel_id / 256u - 1u; channel_id >= 256 && place < vesc.size()) {
    d = &vesc[place];
    controller = channel_id & 0xFFu;
    can_id = d->id << 8 | controller;
    schema = static_cast<std::uint16_t>(2 + saul.size() + place);
  }
  if (d == nullptr) return false;
  if (!out.has_schema(schema))
    out.add_schema(schema,
                   fmt::format("{}.{}", d->protocol == signals::Protocol::vesc_can ? "vesc" : "saul", short_name(*d)),
                   "jsonschema", mcap_json_schema(*d));
  out.add_channel(channel_id, schema, mcap_topic(*d, controller), "json",
                  {{"can_id", fmt::format("0x{:X}", can_id)}, {"sender", d->sender}, {"receiver", d->receiver}});
  return true;
}

std::unique_ptr<CaptureWriter> open_mcap_signal_writer(const std::string& path, McapWriterOptions options,
                                                       const McapMap& metadata) {
  return open_mcap_writer(path, std::move(options), [] { return std::make_unique<McapSignalChannels>(); }, metadata);
}

}  // namespace saul::host
