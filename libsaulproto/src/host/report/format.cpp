#include "saulproto/host/report/format.hpp"

#include <fmt/format.h>

#include <type_traits>

#include "saulproto/host/capture/candump.hpp"

namespace saul::host {
namespace {

// Enums print by name (found by argument-dependent lookup of to_string in the enum's namespace),
// floats in shortest form, integers as numbers.
template <class T>
std::string text_of(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return to_string(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return fmt::format("{:g}", v);
  } else if constexpr (std::is_integral_v<T>) {
    return fmt::format("{}", +v);  // + promotes uint8_t so it prints as a number
  } else {
    return fmt::format("{}", v);
  }
}

template <class T>
nlohmann::json json_of(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return to_string(v);
  } else if constexpr (std::is_integral_v<T>) {
    return +v;
  } else {
    return v;
  }
}

template <class M>
std::string describe_one(const M& m) {
  std::string s = M::kName;
  m.fields([&](const char* name, const auto& value) {
    s += ' ';
    s += name;
    s += '=';
    s += text_of(value);
  });
  return s;
}

template <class M>
nlohmann::json json_one(const M& m) {
  nlohmann::json j;
  j["type"] = M::kName;
  m.fields([&](const char* name, const auto& value) { j[name] = json_of(value); });
  return j;
}

}  // namespace

std::string describe(const BusMessage& message) {
  return std::visit([](const auto& m) { return describe_one(m); }, message);
}
std::string describe(const interboard::Message& message) {
  return std::visit([](const auto& m) { return describe_one(m); }, message);
}
std::string describe(const crsf::Message& message) {
  return std::visit([](const auto& m) { return describe_one(m); }, message);
}
std::string describe(const pride::Message& message) {
  return std::visit([](const auto& m) { return describe_one(m); }, message);
}
nlohmann::json to_json(const BusMessage& message) {
  return std::visit([](const auto& m) { return json_one(m); }, message);
}
nlohmann::json to_json(const interboard::Message& message) {
  return std::visit([](const auto& m) { return json_one(m); }, message);
}

nlohmann::json to_json(const crsf::Message& message) {
  return std::visit([](const auto& m) { return json_one(m); }, message);
}
nlohmann::json to_json(const pride::Message& message) {
  return std::visit([](const auto& m) { return json_one(m); }, message);
}

nlohmann::json frame_to_json(const CanFrame& frame) {
  nlohmann::json j;
  j["id"] = frame.id;
  j["extended"] = frame.extended;
  j["remote"] = frame.remote;
  j["error"] = frame.error;
  j["dlc"] = frame.dlc;
  std::string hex;
  for (std::uint8_t b : frame.payload()) hex += fmt::format("{:02X}", b);
  j["data"] = hex;
  if (frame.timestamp_ns) j["timestamp_ns"] = *frame.timestamp_ns;
  return j;
}

}  // namespace saul::host
