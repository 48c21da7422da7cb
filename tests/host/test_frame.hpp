// A CAN frame written out in a test: id, extended or not, the payload bytes (dlc = their count) and the time.
#pragma once

#include <cstdint>
#include <vector>

#include "saulproto/core/can_frame.hpp"

namespace saul_test {

inline saul::CanFrame frame(std::uint32_t id, bool extended, std::vector<std::uint8_t> data, std::uint64_t ns) {
  saul::CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) f.data[i] = data[i];
  f.timestamp_ns = ns;
  return f;
}

}  // namespace saul_test
