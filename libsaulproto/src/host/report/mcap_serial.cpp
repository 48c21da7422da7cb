#include "saulproto/host/report/mcap_serial.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <charconv>
#include <stdexcept>
#include <variant>

#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/mcap_signals.hpp"

namespace saul::host {
namespace {

/// A CRSF frame that did not decode, as to_json(CrsfUndecoded) gives it (serial_decode.cpp).
nlohmann::json undecoded_schema() {
  const nlohmann::json props = {
      {"type", {{"type", "string"}, {"description", "crsf_0xTT: the frame's type byte"}}},
      {"error", {{"type", "string"}, {"description", "why it did not decode (unknown_type, ...)"}}},
      {"address", {{"type", "integer"}, {"minimum", 0}, {"maximum", 255}, {"description", "the frame's address byte"}}},
      {"payload", {{"type", "string"}, {"description", "the payload bytes in hex"}}}};
  return {{"title", "crsf_undecoded"},
          {"description", "a CRSF frame with a good CRC that did not decode, as saulctl decode --json's \"error\""},
          {"type", "object"},
          {"properties", props},
          {"required", {"type", "error", "address", "payload"}},
          {"additionalProperties", false}};
}

/// One message per chunk on /serial/bytes.
std::string bytes_schema() {
  const nlohmann::json props = {
      {"link",
       {{"type", "string"},
        {"description", "the link, as saulctl names links (serial:DEVICE@BAUD:FORMAT) or as the capture names it"}}},
      {"protocol",
       {{"enum", {"raw", "interboard", "crsf", "pride"}},
        {"description", "what the capture says the bytes carry (raw: it does not say)"}}},
      {"data", {{"type", "string"}, {"description", "the bytes in hex, exactly as received"}}},
      {"uart_errors",
       {{"type", "array"},
        {"items", {{"enum", {"parity", "framing", "break"}}}},
        {"description", "UART errors a logic analyser reported with these bytes"}}}};
  return nlohmann::json{{"title", "saul.serial_chunk"},
                        {"description", "the bytes of one serial link as captured: what one read() of the port "
                                        "returned, or one byte of a logic-analyser export"},
                        {"type", "object"},
                        {"properties", props},
                        {"required", {"link", "protocol", "data", "uart_errors"}},
                        {"additionalProperties", false}}
      .dump();
}

/// The channel of a message: its name, or "undecoded" for a decode error (whose name holds the type byte).
std::string kind_of(const SerialMessage& message) {
  return is_decode_error(message) ? std::string("undecoded") : name_of(message);
}

}  // namespace

std::string mcap_serial_topic(SerialProtocol protocol, std::size_t nth_link_of_protocol, std::string_view kind) {
  if (nth_link_of_protocol > 1) return fmt::format("/serial/{}_{}/{}", to_string(protocol), nth_link_of_protocol, kind);
  return fmt::format("/serial/{}/{}", to_string(protocol), kind);
}

std::string mcap_serial_json_schema(const SerialMessage& message) {
  if (is_decode_error(message)) return undecoded_schema().dump();
  // every other message is described; a serial message keeps decode's "type" (a few a second, not one per frame)
  std::string schema = mcap_json_schema(*signal_values(message).message, true);
  if (std::holds_alternative<CrsfMessage>(message)) {  // to_json() adds the frame's address
    auto j = nlohmann::json::parse(schema);
    j["properties"]["address"] = {{"type", "integer"}, {"minimum", 0}, {"maximum", 255},
                                  {"description", "the frame's address byte (200 = 0xC8, the flight controller)"}};
    j["required"].push_back("address");
    schema = j.dump();
  }
  return schema;
}

LinkLine link_line_settings(std::string_view link) {
  LinkLine out;
  const auto at = link.rfind('@');
  if (at == std::string_view::npos) return out;
  std::string_view rest = link.substr(at + 1);
  std::uint32_t baud = 0;
  const auto [end, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), baud);
  if (ec != std::errc() || baud == 0) return out;
  out.baud = baud;
  rest.remove_prefix(static_cast<std::size_t>(end - rest.data()));
  if (rest.starts_with(':')) out.format = std::string(rest.substr(1));
  return out;
}

McapSerialChannels::McapSerialChannels(McapWriter& out, std::optional<SerialProtocol> fallback)
    : out_(out), decoder_(fallback) {
  callback_ = [this](const SerialChunk& chunk, SerialProtocol protocol, const SerialMessage& m) {
    on_message(chunk, protocol, m);
  };
  const auto schema = out_.add_schema("saul.serial_chunk", "jsonschema", bytes_schema());
  bytes_channel_ = out_.add_channel(schema, kMcapSerialBytesTopic, "json");
}

void McapSerialChannels::add(const SerialChunk& chunk) {
  nlohmann::json j;
  j["link"] = chunk.link;
  j["protocol"] = std::string(to_string(chunk.protocol));
  j["data"] = fmt::format("{:02X}", fmt::join(chunk.bytes, ""));
  j["uart_errors"] = nlohmann::json::array();
  if (chunk.errors & uart_error::kParity) j["uart_errors"].push_back("parity");
  if (chunk.errors & uart_error::kFraming) j["uart_errors"].push_back("framing");
  if (chunk.errors & uart_error::kBreak) j["uart_errors"].push_back("break");
  out_.add_message(bytes_channel_, chunk.timestamp_ns.value_or(0), json_line(j));
  decoder_.add(chunk, callback_);
}

void McapSerialChannels::on_message(const SerialChunk& chunk, SerialProtocol protocol, const SerialMessage& m) {
  const std::string kind = kind_of(m);
  auto channel = channels_.find({chunk.link, kind});
  if (channel == channels_.end()) {
    auto schema = schemas_.find({protocol, kind});
    if (schema == schemas_.end()) {
      const std::string name = fmt::format("saul.{}.{}", to_string(protocol), kind);
      schema = schemas_.emplace(std::pair{protocol, kind}, out_.add_schema(name, "jsonschema", mcap_serial_json_schema(m)))
                   .first;
    }
    auto nth = nth_link_.find(chunk.link);
    if (nth == nth_link_.end()) nth = nth_link_.emplace(chunk.link, ++links_of_[protocol]).first;
    McapMap metadata = {{"link", chunk.link}, {"protocol", std::string(to_string(protocol))}};
    const LinkLine line = link_line_settings(chunk.link);
    if (line.baud) metadata.emplace_back("baud", std::to_string(*line.baud));
    if (!line.format.empty()) metadata.emplace_back("format", line.format);
    channel = channels_
                  .emplace(std::pair{chunk.link, kind},
                           out_.add_channel(schema->second, mcap_serial_topic(protocol, nth->second, kind), "json",
                                            metadata))
                  .first;
  }
  out_.add_message(channel->second, chunk.timestamp_ns.value_or(0), json_line(to_json(m)));
  ++messages_;
}

void McapSerialChannels::finish() {
  decoder_.finish(callback_);
  for (const auto& link : decoder_.links()) {
    McapMap entries = {{"link", link.name},
                       {"protocol", std::string(to_string(link.protocol))},
                       {"protocol_guessed", link.guessed ? "true" : "false"}};
    const LinkLine line = link_line_settings(link.name);
    if (line.baud) entries.emplace_back("baud", std::to_string(*line.baud));
    if (!line.format.empty()) entries.emplace_back("format", line.format);
    entries.emplace_back("counters", link.counters_text);
    for (const auto& [key, value] : link.counters_json.items())  // the counts (its protocol is above already)
      if (value.is_number()) entries.emplace_back(key, value.dump());
    out_.add_metadata("serial_link", entries);
  }
}

namespace {
/// `mcap` after its Metadata record "saulctl" (when `metadata` holds anything): first in the file, before the
/// channels McapSerialChannels adds.
McapWriter& with_metadata(McapWriter& mcap, const McapMap& metadata) {
  if (!metadata.empty()) mcap.add_metadata("saulctl", metadata);
  return mcap;
}
}  // namespace

McapSerialWriter::McapSerialWriter(std::ostream& out, McapWriterOptions options, const McapMap& metadata,
                                   std::optional<SerialProtocol> fallback)
    : mcap_(out, std::move(options)), channels_(with_metadata(mcap_, metadata), fallback) {}

void McapSerialWriter::write(const SerialChunk& chunk) {
  if (closed_) throw std::runtime_error("mcap: the writer is closed");
  channels_.add(chunk);
}

void McapSerialWriter::close() {
  if (closed_) return;
  closed_ = true;
  channels_.finish();
  mcap_.close();
}

}  // namespace saul::host
