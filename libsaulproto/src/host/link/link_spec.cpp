#include "saulproto/host/link/link_spec.hpp"

#include <fmt/format.h>

#include "saulproto/core/quantity.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/link/socketcan.hpp"

namespace saul::host {
namespace {

const char* kForms =
    "use can0 | socketcan:can0 | slcan:/dev/ttyACM0[@500000] | serial:/dev/ttyUSB0@460800[:8N1]";

// A bit or baud rate as every rate is typed: 500000, 500k, 1M (k and M are 1000s).
std::uint32_t parse_rate(const std::string& text, const std::string& whole) {
  const auto v = quantity::parse(text, {}, 1e3).value_or(0);
  if (v == 0 || v > 20'000'000)
    throw std::invalid_argument(fmt::format("bad rate '{}' in link '{}': {}", text, whole, kForms));
  return static_cast<std::uint32_t>(v);
}

}  // namespace

// The kinds both errors have; any other converts to io.
constexpr std::pair<SerialError::Kind, LinkError::Kind> kSameKinds[] = {
    {SerialError::Kind::not_found, LinkError::Kind::not_found},
    {SerialError::Kind::permission, LinkError::Kind::permission},
    {SerialError::Kind::busy, LinkError::Kind::busy},
    {SerialError::Kind::gone, LinkError::Kind::gone}};

LinkError to_link_error(const SerialError& e) {
  for (const auto& [serial, link] : kSameKinds)
    if (serial == e.kind()) return {link, e.what()};
  return {LinkError::Kind::io, e.what()};
}

SerialError to_serial_error(const LinkError& e) {
  for (const auto& [serial, link] : kSameKinds)
    if (link == e.kind()) return {serial, e.what()};
  return {SerialError::Kind::io, e.what()};
}

std::string LinkSpec::text() const {
  switch (kind) {
    case Kind::socketcan: return device;
    case Kind::slcan: return fmt::format("slcan:{}@{}", device, bitrate);
    case Kind::serial: return fmt::format("serial:{}@{}:{}", device, serial.baud, to_string(serial));
  }
  return device;
}

LinkSpec parse_link_spec(const std::string& text) {
  LinkSpec spec;
  if (text.empty()) throw std::invalid_argument(std::string("no link given: ") + kForms);
  const auto colon = text.find(':');
  const std::string scheme = colon == std::string::npos ? "" : text.substr(0, colon);
  const std::string rest = colon == std::string::npos ? text : text.substr(colon + 1);
  if (scheme.empty() || scheme == "socketcan") {
    if (rest.empty() || rest.find('/') != std::string::npos)
      throw std::invalid_argument(fmt::format("'{}' is not a CAN interface name: {}", text, kForms));
    spec.kind = LinkSpec::Kind::socketcan;
    spec.device = rest;
    return spec;
  }
  const auto at = rest.find('@');
  spec.device = rest.substr(0, at);
  if (scheme == "slcan") {
    spec.kind = LinkSpec::Kind::slcan;
    if (at != std::string::npos) spec.bitrate = parse_rate(rest.substr(at + 1), text);
  } else if (scheme == "serial") {
    spec.kind = LinkSpec::Kind::serial;
    if (at == std::string::npos)
      throw std::invalid_argument(fmt::format("serial link '{}' needs a baud rate, e.g. serial:{}@460800", text, rest));
    std::string rate = rest.substr(at + 1);
    const auto fmt_colon = rate.find(':');
    if (fmt_colon != std::string::npos) {
      if (!parse_frame_format(rate.substr(fmt_colon + 1), spec.serial))
        throw std::invalid_argument(fmt::format("bad frame format in '{}': use 8N1, 8E1, ...", text));
      rate = rate.substr(0, fmt_colon);
    }
    spec.serial.baud = parse_rate(rate, text);
  } else {
    throw std::invalid_argument(fmt::format("unknown link type '{}': {}", scheme, kForms));
  }
  if (spec.device.empty()) throw std::invalid_argument(fmt::format("link '{}' names no device: {}", text, kForms));
  return spec;
}

std::unique_ptr<CanLink> open_can_link(const LinkSpec& spec, const LinkOpenOptions& options) {
  switch (spec.kind) {
    case LinkSpec::Kind::socketcan: return open_socketcan(spec.device, {.filters = options.filters});
    case LinkSpec::Kind::slcan: return open_shared_slcan(spec, options.listen_only, options.filters, options.paced);
    case LinkSpec::Kind::serial: break;
  }
  throw std::invalid_argument(fmt::format("'{}' is a serial byte link, not a CAN bus", spec.text()));
}

std::unique_ptr<SerialPort> open_serial_link(const LinkSpec& spec) {
  if (spec.kind != LinkSpec::Kind::serial)
    throw std::invalid_argument(fmt::format("'{}' is a CAN link, not a serial byte link", spec.text()));
  return open_shared_serial(spec.device, spec.serial);
}

}  // namespace saul::host
