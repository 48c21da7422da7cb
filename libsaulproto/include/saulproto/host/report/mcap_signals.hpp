// The decoded signals of a CAN capture as MCAP channels, for Foxglove, Lichtblick and PlotJuggler: one channel per
// message kind (and per VESC controller), each with a JSON Schema of its fields (units in the descriptions) made
// from the signal descriptions (core/signals.hpp), and messages that are the "message" object of
// `saulctl decode --json` (format.hpp's append_message()) without what the topic says, its "type" and a VESC's
// "controller_id" (MessageFormat::mcap_json: a fifth of a decoded message's bytes, compressed for every frame),
// so a plot in a viewer shows the numbers decode prints.
//
// Topics: "/saul/<name>" for the robot's own messages ("/saul/telemetry_a"), "/vesc/<controller>/<name>" for a
// VESC's status messages ("/vesc/68/status_1"). Frames that do not decode (unknown id, rejected, error and
// remote frames) are on "/can/frames" only. docs/captures.md lists them.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "saulproto/core/signals.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/report/frame_key.hpp"

namespace saul::host {

/// "/saul/telemetry_a", "/vesc/68/status_1" (controller: the VESC's id, ignored for other protocols).
std::string mcap_topic(const signals::MessageDesc& message, std::uint32_t controller);
/// The JSON Schema of a CAN channel's messages: every signal's key with its unit, but for what the topic says
/// (MessageFormat::mcap_json); `with_type`: with "type" too (a serial channel's, mcap_serial.hpp: to_json()'s).
std::string mcap_json_schema(const signals::MessageDesc& message, bool with_type = false);

/// The channel id of a message kind's decoded messages, the same in every file (so that threads converting blocks
/// of a file apart give the ids the file's one list would): 1 + the message's place in the robot's table, or for a
/// VESC's 256 x (1 + its place in the VESC table) + the controller. "/can/frames" is 0. Schemas: 2 + the place in
/// the robot's table, then the VESC's.
std::uint16_t mcap_channel_id(const signals::MessageDesc& message, std::uint32_t controller);

/// Adds the decoded channels to an McapCaptureWriter (McapFrameExtra); one per thread (its cache).
class McapSignalChannels final : public McapFrameExtra {
 public:
  void on_frame(const CanFrame& frame, std::uint64_t log_time, std::string_view interface_json,
                McapChunk& chunk) override;
  /// The schema (when new) and the channel of an id mcap_channel_id() gives.
  bool declare(McapWriter& out, std::uint16_t channel_id) override;

 private:
  /// Robot buses repeat payloads: what a frame's content gives (its "/can/frames" JSON up to the interface, then
  /// its decoded message's JSON when it decodes, and that message's channel) is kept in a direct-mapped table by
  /// frame_key(), as decode's FrameEmitter keeps its lines, so most frames are not rendered again. The keys sit in
  /// an array of their own (64 KiB, in the CPU's cache), looked at for every frame; the text only on a hit.
  struct Rendered {
    std::uint16_t channel = 0;
    bool decoded = false;
    std::size_t head = 0;  ///< text's first `head` bytes: mcap_frame_json_head(); the decoded JSON after them
    std::string text;
  };
  /// Renders a frame not in the table into `slot`.
  static void render(const CanFrame& frame, Rendered& slot);
  static constexpr std::size_t kCache = 4096;
  std::vector<FrameKey> keys_ = std::vector<FrameKey>(kCache, FrameKey{~std::uint64_t{0}, 0});  ///< ~0: no frame's
  std::vector<Rendered> cache_ = std::vector<Rendered>(kCache);
};

/// An MCAP writer of CAN frames with the decoded channels (open_mcap_writer with McapSignalChannels).
std::unique_ptr<CaptureWriter> open_mcap_signal_writer(const std::string& path, McapWriterOptions options,
                                                       const McapMap& metadata);

}  // namespace saul::host
