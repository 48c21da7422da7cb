#include "saulproto/host/report/frame_text.hpp"

#include <linux/can/error.h>

#include <fmt/format.h>

#include <charconv>
#include <iterator>
#include <utility>

#include "saulproto/host/report/format.hpp"

namespace saul::host {

std::string describe_error_frame(const CanFrame& f) {
  std::string s;
  for (const auto& c : kErrorClasses) {
    if ((f.id & c.bit) == 0) continue;
    if (!s.empty()) s += ", ";
    if (c.text != nullptr) {
      const auto& d = f.data;  // {n} in the text is data byte n
      s += fmt::format(fmt::runtime(c.text), d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7]);
      continue;
    }
    constexpr std::pair<unsigned, const char*> kStatus[] = {
        {CAN_ERR_CRTL_RX_OVERFLOW, " rx-overflow"}, {CAN_ERR_CRTL_TX_OVERFLOW, " tx-overflow"},
        {CAN_ERR_CRTL_RX_WARNING, " rx-warning"},   {CAN_ERR_CRTL_TX_WARNING, " tx-warning"},
        {CAN_ERR_CRTL_RX_PASSIVE, " rx-passive"},   {CAN_ERR_CRTL_TX_PASSIVE, " tx-passive"},
        {CAN_ERR_CRTL_ACTIVE, " back-to-error-active"}};
    std::string d;
    for (const auto& [bit, name] : kStatus)
      if (f.data[1] & bit) d += name;
    s += "controller:" + (d.empty() ? std::string(" problem") : d);
  }
  return s.empty() ? std::string("error frame") : s;
}

char* TimeColumn::write(char* w, std::uint64_t ns, bool parens) {
  // "({:010}.{:06})" absolute, "({:>4}.{:06})" relative or delta: a time before the first frame's (relative) or the
  // previous one's (delta: the log's times went back) is negative, "(  -0.050000)".
  if (!first_) first_ = ns;
  std::uint64_t shown = ns;
  bool negative = false;
  if (mode_ != TimeMode::absolute) {
    const std::uint64_t from = mode_ == TimeMode::relative ? *first_ : previous_.value_or(ns);
    negative = ns < from;
    shown = negative ? from - ns : ns - from;
  }
  previous_ = ns;
  const std::uint64_t sec = shown / 1'000'000'000ULL;
  auto usec = static_cast<std::uint32_t>((shown % 1'000'000'000ULL) / 1000);
  if (!seconds_ || sec != *seconds_ || negative != seconds_negative_) {  // the same for thousands of frames
    char digits[24];
    char* end = digits;
    if (negative) *end++ = '-';
    end = std::to_chars(end, std::end(digits), sec).ptr;
    const auto n = static_cast<std::size_t>(end - digits);
    const std::size_t width = mode_ == TimeMode::absolute ? 10 : 4;
    seconds_text_.assign(n < width ? width - n : 0, mode_ == TimeMode::absolute ? '0' : ' ');
    seconds_text_.append(digits, n);
    seconds_text_ += '.';
    seconds_ = sec;
    seconds_negative_ = negative;
  }
  if (parens) *w++ = '(';
  w = put_chars(w, seconds_text_);
  for (int i = 5; i >= 0; --i, usec /= 10) w[i] = static_cast<char>('0' + usec % 10);
  w += 6;
  if (parens) *w++ = ')';
  return w;
}

std::string TimeColumn::operator()(std::uint64_t ns) {
  char text[kMaxChars];
  return std::string(text, write(text, ns));
}

}  // namespace saul::host
