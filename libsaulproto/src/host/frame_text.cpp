#include "saulproto/host/frame_text.hpp"

#include <fmt/format.h>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/candump.hpp"
#include "saulproto/host/format.hpp"
#include "saulproto/host/socketcan.hpp"

namespace saul::host {

std::string TimeColumn::operator()(std::uint64_t ns) {
  if (!first_) first_ = ns;
  std::uint64_t shown = ns;
  if (mode_ == TimeMode::relative) shown = ns >= *first_ ? ns - *first_ : 0;
  if (mode_ == TimeMode::delta) shown = previous_ && ns >= *previous_ ? ns - *previous_ : 0;
  previous_ = ns;
  const std::uint64_t sec = shown / 1'000'000'000ULL;
  const std::uint64_t usec = (shown % 1'000'000'000ULL) / 1000;
  if (mode_ == TimeMode::absolute) return fmt::format("({:010}.{:06})", sec, usec);
  return fmt::format("({:4}.{:06})", sec, usec);
}

std::string describe_frame(const CanFrame& frame) {
  if (frame.error) return "!error_frame " + describe_error_frame(frame);
  const auto r = decode_bus_frame(frame);
  if (r) return describe(r.value());
  return std::string("!") + to_string(r.reason());
}

std::string frame_line(const std::string& time_column, std::string_view interface, const CanFrame& frame) {
  return fmt::format("{} {} {:<24} {}", time_column, interface, format_candump_frame(frame), describe_frame(frame));
}

nlohmann::json frame_record(const std::string& time_column, std::string_view interface, const CanFrame& frame) {
  nlohmann::json j;
  j["time"] = TimeColumn::bare(time_column);
  j["interface"] = interface;
  j["frame"] = frame_to_json(frame);
  const auto r = decode_bus_frame(frame);
  if (r) {
    j["message"] = to_json(r.value());
  } else {
    j["error"] = to_string(r.reason());
    if (frame.error) j["error_detail"] = describe_error_frame(frame);
  }
  return j;
}

}  // namespace saul::host
