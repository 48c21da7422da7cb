// Text and JSON renderings of decoded messages, for saulctl and for logs.
//
// Works for any message type with kName and fields(visitor) (every core message has them), so a new message
// type prints without touching this file.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/core/crsf.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/core/result.hpp"

namespace saul::host {

/// "velocity_cmd speed_mmps=1000 steer_mrad=-500"
std::string describe(const BusMessage& message);
std::string describe(const interboard::Message& message);
std::string describe(const crsf::Message& message);
std::string describe(const pride::Message& message);

/// {"type":"velocity_cmd","speed_mmps":1000,"steer_mrad":-500}
nlohmann::json to_json(const BusMessage& message);
nlohmann::json to_json(const interboard::Message& message);
nlohmann::json to_json(const crsf::Message& message);
nlohmann::json to_json(const pride::Message& message);

/// The frame itself: {"id":768,"extended":false,"remote":false,"error":false,"dlc":4,"data":"E8030CFE"}
nlohmann::json frame_to_json(const CanFrame& frame);

}  // namespace saul::host
