// Replaying a serial byte capture onto a serial port: each chunk at its own timestamp, on CAN replay's deadlines,
// speed and loops (replay.hpp), without the messages that can move motors unless motion is allowed. Apart from any
// real clock or port, so tests drive it with a fake clock and sink.
//
// SerialFrameSplitter cuts the bytes into frames by the core's streaming decoders' own rule: a byte starts a frame
// exactly when the decoder, fed the stream from that byte on, delivers a frame without skipping it; so the frames
// are exactly those the decoders find. A motion frame's bytes are left out, every other byte is written as captured.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/link/link_spec.hpp"
#include "saulproto/host/replay/replay.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saul::host {

/// Whether a message, arriving on its link, can make a motor move; what a serial replay drops without motion
/// allowed. O(1).
///  - inter-board: RC_CMD (throttle, steer, the armed flag), unless its kill flag (bit 1, estop) is set;
///  - CRSF: RC_CHANNELS_PACKED (the sticks and the arm switch drive the robot through the IO board), unless CH6
///    asks for estop (> 1500 us); an RC frame whose CRC checks but whose payload does not decode counts as motion
///    (a receiver's firmware may read it anyway);
///  - Pride: every VCU command (FE 54: speed level and the drive stick), whatever its values, as 0x300 on CAN.
/// Never: SENSOR, FAULT, STATE, LED_CMD, BUZZER; CRSF telemetry, link statistics and other types; the Pride
/// controller status. Estops (RC_CMD kill, CRSF CH6, FAULT estop) always go through.
bool can_move_motors(const SerialMessage& message);

/// A piece of one link's byte stream: one frame of the link's protocol, or bytes that belong to no frame.
struct SerialPiece {
  std::size_t size = 0;                  ///< bytes
  std::optional<SerialMessage> message;  ///< the frame's message; empty for bytes in no frame
  bool motion = false;                   ///< can_move_motors(*message)
};

/// Cuts one link's byte stream into pieces, in stream order, as the bytes come (see the top of this file). At most
/// one frame is held back (64 bytes for CRSF); noise is handed out as soon as it is known. raw: every byte is in no
/// frame. Memory: the held bytes. Work: O(frame size) per byte at worst, O(1) on clean frames.
class SerialFrameSplitter {
 public:
  using Callback = std::function<void(const SerialPiece&)>;
  explicit SerialFrameSplitter(SerialProtocol protocol) : protocol_(protocol) {}

  /// Feeds bytes; calls on_piece for every piece they complete.
  void push(std::span<const std::uint8_t> bytes, const Callback& on_piece);
  /// End of the stream: an unfinished frame gives up its first byte (in no frame) and what followed is searched
  /// again, as crsf::StreamDecoder::flush() does; every byte held ends up in a piece.
  void finish(const Callback& on_piece);
  /// Bytes pushed that are in no piece yet.
  [[nodiscard]] std::size_t pending() const { return held_.size() + noise_; }

 private:
  void resolve(bool at_end, const Callback& on_piece);
  void emit_noise(const Callback& on_piece);
  SerialProtocol protocol_;
  std::deque<std::uint8_t> held_;              // bytes not in a piece yet (after the noise_ run)
  std::size_t noise_ = 0;                      // bytes in no frame, known, not yet handed out
  std::optional<SerialStreamDecoder> probe_;   // fed held_[0 .. fed_): does a frame start at held_[0]?
  std::size_t fed_ = 0;
  std::optional<SerialMessage> found_;
};

/// Serial settings for replaying a captured link when --to names none: the captured link's own when its name is
/// a serial link (serial:/dev/ttyUSB0@460800:8N1, as record writes it), else the protocol's: inter-board 460800
/// 8N1, CRSF 420000 8N1, Pride 38400 8E1 (docs/protocol.md). nullopt for a raw link with no rate in its name.
/// A captured name with a rate but no frame format takes the protocol's format (8N1 for raw).
std::optional<SerialSettings> replay_serial_settings(std::string_view captured_link, SerialProtocol protocol);

/// The port a serial replay writes to: serial:DEV, serial:DEV@BAUD or serial:DEV@BAUD:FORMAT (link_spec.hpp),
/// what is left out coming from `defaults` (replay_serial_settings). Throws std::invalid_argument with the accepted
/// forms, also when no baud rate is given and there is no default.
LinkSpec parse_serial_replay_link(const std::string& text, const std::optional<SerialSettings>& defaults);

struct SerialReplayOptions : ReplayPacing {
  /// The captured link to replay; chunks of other links are not sent. Empty: the first link of the file.
  std::string link;
  /// How to cut the link's bytes into frames; empty: the protocol its first chunk names. A raw link is sent as it
  /// is (nothing can be recognised, nothing is dropped): check for that before replaying it without motion.
  std::optional<SerialProtocol> protocol;
};

struct SerialReplayReport : ReplayTotals {  ///< lateness: per write
  std::uint64_t chunks = 0;       ///< chunks of the replayed link read (all passes)
  std::uint64_t bytes = 0;        ///< their bytes
  std::uint64_t writes = 0;       ///< chunks written (those with bytes left after dropping)
  std::uint64_t bytes_sent = 0;
  std::uint64_t frames = 0;       ///< frames of the protocol found in the bytes read
  std::uint64_t motion_dropped = 0;   ///< messages left out
  std::uint64_t motion_bytes = 0;     ///< their bytes
  std::map<std::string, std::uint64_t> motion_by_type;  ///< "rc_cmd" -> messages left out
  std::uint64_t motion_sent = 0;  ///< messages that can move motors sent (motion allowed)
  std::uint64_t other_links = 0;  ///< chunks of other links (not sent)
  std::uint64_t corrupt = 0;      ///< corrupt records of the file (all passes)
  SerialProtocol protocol = SerialProtocol::raw;  ///< what the bytes were cut with
  std::string link;               ///< the captured link replayed
};

struct SerialReplayHooks {
  /// Required: writes one chunk's bytes (what is left of them); exceptions pass through replay_serial().
  std::function<void(std::span<const std::uint8_t>)> write;
  /// Single step: called with each chunk about to be written and the bytes that will go out; false stops. The
  /// schedule is re-anchored after it.
  std::function<bool(const SerialChunk& chunk, std::span<const std::uint8_t> bytes)> step;
  std::function<void(const CaptureError&)> on_corrupt;
  std::function<bool()> stop;  ///< polled before each write; true ends the replay
};

/// Replays options.loops passes of the capture that open_pass() opens (called once per pass). A chunk is written
/// once every byte of it is decided (at most one frame of look-ahead), at its deadline; chunks with nothing left to
/// write are not scheduled (as filtered CAN frames), the schedule follows the timestamps of the chunks written.
/// Each pass cuts its bytes afresh (an unfinished frame at the end of the file is written as it is).
SerialReplayReport replay_serial(const std::function<std::unique_ptr<SerialCaptureReader>()>& open_pass,
                                 const SerialReplayOptions& options, ReplayClock& clock,
                                 const SerialReplayHooks& hooks);

/// One link of a serial capture, as a replay would see it (one pass).
struct SerialLinkPreview {
  std::string name;
  SerialProtocol protocol = SerialProtocol::raw;  ///< as the file names it, else guessed, else raw
  bool guessed = false;                           ///< guessed from the first 4 KiB (guess_serial_protocol)
  std::uint64_t chunks = 0;
  std::uint64_t bytes = 0;
  std::uint64_t frames = 0;
  std::uint64_t motion = 0;        ///< messages that can move motors
  std::uint64_t motion_bytes = 0;
  std::map<std::string, std::uint64_t> motion_by_type;
  std::uint64_t writes = 0;        ///< chunks that still have bytes without the motion messages
};

struct SerialReplayPreview {
  std::vector<SerialLinkPreview> links;  ///< in order of first appearance
  std::uint64_t corrupt = 0;
  [[nodiscard]] const SerialLinkPreview* find(std::string_view name) const;
};

/// One pass over a serial capture: its links, their protocols (links whose chunks say raw get `fallback` when
/// given, else a guess from their first 4 KiB of bytes) and what a replay without motion would leave out.
SerialReplayPreview preview_serial_replay(SerialCaptureReader& reader,
                                          std::optional<SerialProtocol> fallback = std::nullopt);

/// "rc_cmd 3, vcu_command 1" (most frequent first, then by name); "" when empty.
std::string format_motion_by_type(const std::map<std::string, std::uint64_t>& by_type);

}  // namespace saul::host
