#include "saulproto/host/link/link_spec.hpp"

#include <fmt/format.h>

#include "saulproto/core/quantity.hpp"
#include "saulproto/host/link/shared_link.hpp"
#include "saulproto/host/link/slcan_link.hpp"
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

LinkError to_link_error(const SerialError& e) {
  switch (e.kind()) {
    case SerialError::Kind::not_found: return {LinkError::Kind::not_found, e.what()};
    case SerialError::Kind::permission: return {LinkError::Kind::permission, e.what()};
    case SerialError::Kind::busy: return {LinkError::Kind::busy, e.what()};
    case SerialError::Kind::gone: return {LinkError::Kind::gone, e.what()};
    default: return {LinkError::Kind::io, e.what()};
  }
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
  if (scheme == "slcan") {
    spec.kind = LinkSpec::Kind::slcan;
    const auto at = rest.find('@');
    spec.device = rest.substr(0, at);
    if (at != std::string::npos) spec.bitrate = parse_rate(rest.substr(at + 1), text);
  } else if (scheme == "serial") {
    spec.kind = LinkSpec::Kind::serial;
    const auto at = rest.find('@');
    spec.device = rest.substr(0, at);
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
    case LinkSpec::Kind::socketcan: {
      SocketCanOptions o;
      o.filters = options.filters;
      return open_socketcan(spec.device, o);
    }
    case LinkSpec::Kind::slcan: {
      if (options.share) return open_shared_slcan(spec, options.listen_only, options.filters, options.paced);
      SlcanOptions o;
      o.bitrate = spec.bitrate;
      o.listen_only = options.listen_only;
      o.backend = spec.backend;
      auto link = open_slcan(spec.device, o);
      link->set_filters(options.filters);
      return link;
    }
    case LinkSpec::Kind::serial: break;
  }
  throw std::invalid_argument(fmt::format("'{}' is a serial byte link, not a CAN bus", spec.text()));
}

std::unique_ptr<CanLink> open_can_link(const LinkSpec& spec, bool listen_only) {
  LinkOpenOptions o;
  o.listen_only = listen_only;
  return open_can_link(spec, o);
}

std::unique_ptr<SerialPort> open_serial_link(const LinkSpec& spec) {
  if (spec.kind != LinkSpec::Kind::serial)
    throw std::invalid_argument(fmt::format("'{}' is a CAN link, not a serial byte link", spec.text()));
  return open_shared_serial(spec.device, spec.serial, spec.backend);
}

}  // namespace saul::host
