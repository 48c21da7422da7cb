#include "saulproto/host/capture/gvret_csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <optional>
#include <tuple>
#include <utility>
#include <stdexcept>

#include "capture_io.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

std::string upper_trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  std::string out(s);
  for (char& c : out)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  return out;
}

}  // namespace

GvretCsvReader::Step GvretCsvReader::parse_line(std::string_view line) {
  if (line.find_first_not_of(" \t") == std::string_view::npos) return Step::skipped;
  while (line.back() == ' ') line.remove_suffix(1);
  return std::exchange(have_header_, true) ? row(line) : header(line);
}

GvretCsvReader::Step GvretCsvReader::header(std::string_view line) {
  std::vector<std::pair<std::size_t, std::string_view>> fields;
  detail::split_fields(line, ',', fields);
  static constexpr std::string_view kNames[] = {"TIME STAMP", "ID", "EXTENDED", "BUS", "LEN", "D1"};
  std::array<std::optional<std::size_t>, std::size(kNames)> at;  // the columns of kNames
  for (std::size_t i = 0; i < fields.size(); ++i)
    for (std::size_t k = 0; k < at.size(); ++k)
      if (upper_trimmed(fields[i].second) == kNames[k]) at[k] = i;
  if (std::find(at.begin(), at.end(), std::nullopt) != at.end())
    return corrupt(0, "not SavvyCAN's CSV header (Time Stamp,ID,Extended,Dir,Bus,LEN,D1,...)");
  std::tie(time_, id_, extended_, bus_, len_, data_) = std::tuple(*at[0], *at[1], *at[2], *at[3], *at[4], *at[5]);
  return Step::skipped;
}

GvretCsvReader::Step GvretCsvReader::row(std::string_view line) {
  std::vector<std::pair<std::size_t, std::string_view>> f;
  detail::split_fields(line, ',', f);
  if (f.size() <= std::max({time_, id_, extended_, bus_, len_}))
    return corrupt(line.size(), "fewer fields than the header names");
  const auto us = detail::parse_decimal(f[time_].second);
  if (!us || *us > UINT64_MAX / 1000) return corrupt(f[time_].first, "Time Stamp must be microseconds");
  const auto id = f[id_].second.size() <= 8 ? detail::parse_hex(f[id_].second) : std::nullopt;
  if (!id || *id > CanFrame::kMaxExtendedId) return corrupt(f[id_].first, "ID must be hexadecimal, at most 1FFFFFFF");
  const std::string ext = upper_trimmed(f[extended_].second);
  if (ext != "TRUE" && ext != "FALSE") return corrupt(f[extended_].first, "Extended must be true or false");
  const auto bus = detail::parse_decimal(f[bus_].second);
  if (!bus || *bus > 255) return corrupt(f[bus_].first, "Bus must be a number 0..255");
  const auto len = detail::parse_decimal(f[len_].second);
  if (!len) return corrupt(f[len_].first, "LEN must be a number");
  if (*len > 8) return corrupt(f[len_].first, "LEN above 8 (CAN FD): the robot's bus is classic CAN, FD is not supported");
  CanFrame fr;
  fr.timestamp_ns = *us * 1000;
  fr.id = static_cast<std::uint32_t>(*id);
  fr.extended = ext == "TRUE" || *id > CanFrame::kMaxStandardId;  // SavvyCAN reads a long id as 29-bit too
  fr.dlc = static_cast<std::uint8_t>(*len);
  if (f.size() < data_ + fr.dlc)
    return corrupt(line.size(), fmt::format("LEN is {} but {} data bytes follow", fr.dlc, f.size() > data_ ? f.size() - data_ : 0));
  for (std::size_t i = 0; i < fr.dlc; ++i) {
    const auto [col, text] = f[data_ + i];
    const auto b = text.size() <= 2 ? detail::parse_hex(text) : std::nullopt;
    if (!b) return corrupt(col, "data byte must be 1 or 2 hex digits");
    fr.data[i] = static_cast<std::uint8_t>(*b);
  }
  frame_ = fr;
  name_ = fmt::format("can{}", *bus);
  return Step::frame;
}

// ---- writer ----

void GvretCsvWriter::put(const CanFrame& frame, std::string_view interface) {
  if (frame.remote || frame.error) return;  // the format has neither
  const std::size_t bus = detail::channel_index(buses_, interface, 256, "GVRET CSV");
  std::string line = fmt::format("{},{:08X},{},Rx,{},{},", frame.timestamp_ns.value_or(0) / 1000, frame.id,
                                 frame.extended ? "true" : "false", bus, frame.dlc);
  for (std::size_t i = 0; i < 8; ++i) line += fmt::format("{:02X},", i < frame.dlc ? frame.data[i] : 0);
  out_ << line << '\n';
}

}  // namespace saul::host
