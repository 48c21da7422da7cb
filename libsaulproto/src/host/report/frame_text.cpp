#include "saulproto/host/report/frame_text.hpp"

#include <linux/can/error.h>

#include <fmt/format.h>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {

std::string describe_error_frame(const CanFrame& f) {
  std::string s;
  auto add = [&](const std::string& part) {
    if (!s.empty()) s += ", ";
    s += part;
  };
  if (f.id & CAN_ERR_TX_TIMEOUT) add("tx timeout");
  if (f.id & CAN_ERR_LOSTARB) add(fmt::format("lost arbitration at bit {}", f.data[0]));
  if (f.id & CAN_ERR_CRTL) {
    const std::uint8_t c = f.data[1];
    std::string d;
    if (c & CAN_ERR_CRTL_RX_OVERFLOW) d += " rx-overflow";
    if (c & CAN_ERR_CRTL_TX_OVERFLOW) d += " tx-overflow";
    if (c & CAN_ERR_CRTL_RX_WARNING) d += " rx-warning";
    if (c & CAN_ERR_CRTL_TX_WARNING) d += " tx-warning";
    if (c & CAN_ERR_CRTL_RX_PASSIVE) d += " rx-passive";
    if (c & CAN_ERR_CRTL_TX_PASSIVE) d += " tx-passive";
    if (c & CAN_ERR_CRTL_ACTIVE) d += " back-to-error-active";
    add("controller:" + (d.empty() ? std::string(" problem") : d));
  }
  if (f.id & CAN_ERR_PROT) add(fmt::format("protocol violation type 0x{:02X} at 0x{:02X}", f.data[2], f.data[3]));
  if (f.id & CAN_ERR_TRX) add("transceiver problem");
  if (f.id & CAN_ERR_ACK) add("no ACK (is anything else on the bus? termination?)");
  if (f.id & CAN_ERR_BUSOFF) add("BUS-OFF");
  if (f.id & CAN_ERR_BUSERROR) add("bus error");
  if (f.id & CAN_ERR_RESTARTED) add("controller restarted");
#ifdef CAN_ERR_CNT
  if (f.id & CAN_ERR_CNT) add(fmt::format("tec={} rec={}", f.data[6], f.data[7]));
#endif
  return s.empty() ? std::string("error frame") : s;
}

std::string TimeColumn::operator()(std::uint64_t ns) {
  if (!first_) first_ = ns;
  if (mode_ == TimeMode::absolute) {
    previous_ = ns;
    return fmt::format("({:010}.{:06})", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000);
  }
  // since the first stamp or the previous one; a stamp before it (times that went back) is negative
  const std::uint64_t from = mode_ == TimeMode::relative ? *first_ : previous_.value_or(ns);
  previous_ = ns;
  const bool negative = ns < from;
  const std::uint64_t shown = negative ? from - ns : ns - from;
  return fmt::format("({:>4}.{:06})", fmt::format("{}{}", negative ? "-" : "", shown / 1'000'000'000ULL),
                     (shown % 1'000'000'000ULL) / 1000);
}

std::string describe_frame(const CanFrame& frame) {
  if (frame.error) return "!error_frame " + describe_error_frame(frame);
  const auto r = decode_bus_frame(frame);
  if (r) return describe(r.value());
  return std::string("!") + to_string(r.reason());
}

}  // namespace saul::host
