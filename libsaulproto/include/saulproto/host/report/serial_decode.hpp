// Serial byte streams decoded on the host: the core's stream decoders (inter-board, CRSF, Pride) behind one class,
// their messages in one variant with text and JSON views, and a protocol guess for captures that name none.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/pride.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {

/// A CRSF frame whose CRC checked but which did not decode (a type we do not know, or a short payload).
struct CrsfUndecoded {
  crsf::Frame frame;
  Reason reason = Reason::unknown_type;
};

/// A decoded CRSF frame and its address byte: 0xC8 (the flight controller), 0x00 (broadcast), 0xEA/0xEC/0xEE on a
/// handset <-> TX-module wire. Flight controllers act only on RC frames addressed 0xC8.
struct CrsfMessage {
  std::uint8_t address = crsf::kSyncByte;
  crsf::Message message;
};

using SerialMessage = std::variant<interboard::Message, CrsfMessage, pride::Message, CrsfUndecoded>;

/// "state", "rc_channels", "vcu_command", "crsf_0x3A".
std::string name_of(const SerialMessage& message);
/// Its signals from its description; message nullptr for an undecoded CRSF frame.
SignalValues signal_values(const SerialMessage& message);
/// "state pitch=-12.34° ..."; CRSF with its address after the name ("rc_channels address=0xC8 ch1=…"); an
/// undecoded CRSF frame "!unknown_type crsf address=0xC8 type=0x3A payload=0102".
std::string describe(const SerialMessage& message);
/// {"type":"state",...}; CRSF adds "address" (200 = 0xC8); undecoded: {"type":"crsf_0x3A","error":..,"payload":..}.
nlohmann::json to_json(const SerialMessage& message);
bool is_decode_error(const SerialMessage& message);  ///< an undecoded CRSF frame

/// What a SerialStreamDecoder has seen. Fields a protocol does not have stay 0.
struct SerialDecodeCounters {
  std::uint64_t bytes = 0;
  std::uint64_t frames = 0;          ///< messages delivered (CRSF: frames with a good CRC, decoded or not)
  std::uint64_t crc_errors = 0;      ///< interboard, CRSF: bad CRC; Pride: bad checksum
  std::uint64_t length_errors = 0;   ///< interboard, CRSF
  std::uint64_t unknown_types = 0;   ///< interboard (rejected), CRSF (delivered undecoded)
  std::uint64_t out_of_range = 0;    ///< Pride: good checksum, field outside the manual's range
  std::uint64_t undecoded = 0;       ///< CRSF frames with a good CRC that decode() refused (unknown types included)
  std::uint64_t bytes_skipped = 0;   ///< bytes in no frame
  std::uint64_t incomplete = 0;      ///< unfinished frame at the end (or when given up)
  std::uint64_t uart_errors = 0;     ///< chunks a logic analyser flagged (parity, framing, break)
  /// Everything that is a decode error: crc + length + out of range + undecoded (+ unknown types of interboard).
  [[nodiscard]] std::uint64_t errors(SerialProtocol protocol) const noexcept;
};

/// One streaming decoder for one link. push() bytes as they come; finish() at the end of the capture.
class SerialStreamDecoder {
 public:
  using Callback = std::function<void(const SerialMessage&)>;
  explicit SerialStreamDecoder(SerialProtocol protocol);

  void push(std::span<const std::uint8_t> bytes, const Callback& on_message);
  void note_uart_errors(std::uint8_t errors);  ///< counts a chunk's uart_error bits
  /// End of input: CRSF gives up its unfinished candidate (frames found behind it are still delivered),
  /// interboard and Pride drop theirs; all count it as incomplete.
  void finish(const Callback& on_message);
  [[nodiscard]] std::size_t pending() const;  ///< bytes held in an unfinished frame
  /// Gives up the unfinished candidate as if rejected (its first byte skipped, the rest scanned again, the frames
  /// found delivered) until nothing is pending, each counted incomplete. For a line that went idle.
  void abandon(const Callback& on_message);
  /// While a message is delivered: the stream offset just past its frame's last byte (exact for CRSF; for
  /// interboard and Pride the byte whose push delivered it).
  [[nodiscard]] std::uint64_t frame_end() const { return frame_end_; }
  [[nodiscard]] std::uint64_t bytes_pushed() const { return extra_.bytes; }

  [[nodiscard]] SerialProtocol protocol() const { return protocol_; }
  [[nodiscard]] SerialDecodeCounters counters() const;
  /// "7 frames, 1 crc error, 7 bytes skipped" (the counters this protocol has, zeros included).
  [[nodiscard]] std::string counters_text() const;
  [[nodiscard]] nlohmann::json counters_json() const;

 private:
  template <class Feed>  // the CRSF frames that feed() finds, delivered
  void crsf_frames(const crsf::StreamDecoder& d, Feed&& feed, const Callback& on_message);
  SerialProtocol protocol_;
  std::variant<std::monostate, interboard::StreamDecoder, crsf::StreamDecoder, pride::StreamDecoder> decoder_;
  SerialDecodeCounters extra_;  // bytes, undecoded, incomplete, uart errors: what the core decoders do not count
  std::array<std::uint8_t, 64> recent_{};  // the last bytes pushed (a ring): abandon() rescans them (interboard, Pride)
  std::uint64_t frame_end_ = 0;
  std::uint64_t frame_bytes_ = 0;   // CRSF: bytes of the frames delivered
  std::uint64_t skip_adjust_ = 0;   // interboard, Pride: bytes abandon() made the core count as skipped twice
};

/// How long a link stays quiet before SerialCaptureDecoder gives up a frame in progress: the longest frame's time
/// on the wire, at least 1 ms (CRSF: 1748 us, Betaflight's figure).
std::uint64_t idle_gap_ns(SerialProtocol protocol) noexcept;

/// The protocol of a byte stream: the decoder that finds the most frames, at least 2 and more than its decode
/// errors; nullopt when none does.
std::optional<SerialProtocol> guess_serial_protocol(std::span<const std::uint8_t> bytes);

/// Decodes every link of a capture, a SerialStreamDecoder per link. A link whose chunks say raw gets `fallback`,
/// else a protocol guessed from its first guess_bytes bytes (held back until then). Every message comes with the
/// chunk its frame's last byte came in. After a quiet gap longer than idle_gap_ns(), an unfinished candidate that
/// hides frames is given up (abandon()); one that hides none is kept (a USB adapter may split a frame in two reads).
class SerialCaptureDecoder {
 public:
  /// A message, with the chunk that completed it (its time and link) and the link's protocol.
  using Callback = std::function<void(const SerialChunk& chunk, SerialProtocol protocol, const SerialMessage& m)>;
  explicit SerialCaptureDecoder(std::optional<SerialProtocol> fallback = std::nullopt, std::size_t guess_bytes = 4096)
      : fallback_(fallback), guess_bytes_(guess_bytes) {}
  void add(const SerialChunk& chunk, const Callback& on_message);
  /// End of the capture: decides links still guessing, then ends every decoder.
  void finish(const Callback& on_message);

  struct Link {
    std::string name;
    SerialProtocol protocol = SerialProtocol::raw;
    bool guessed = false;  ///< the protocol was guessed from the bytes
    SerialDecodeCounters counters;
    std::string counters_text;
    nlohmann::json counters_json;
  };
  [[nodiscard]] std::vector<Link> links() const;  ///< in order of first appearance
  /// Links decoded at most, so that a link column of noise takes no decoder per name; the chunks of the others
  /// are counted in unlisted().
  static constexpr std::size_t kMaxLinks = 64;
  struct Unlisted {
    std::uint64_t chunks = 0;
    std::uint64_t bytes = 0;
  };
  [[nodiscard]] const Unlisted& unlisted() const { return unlisted_; }

 private:
  struct State {
    std::string name;
    bool decided = false;
    bool guessed = false;
    std::optional<SerialStreamDecoder> decoder;
    std::vector<SerialChunk> held;  // while guessing
    std::size_t held_bytes = 0;
    std::optional<std::uint64_t> last_ns;  // of the last chunk fed
    // the chunks that may still hold bytes of a frame: (stream offset just past the chunk, its time)
    std::deque<std::pair<std::uint64_t, std::optional<std::uint64_t>>> recent;
  };
  SerialChunk chunk_of(const State& state, std::uint64_t end) const;  // the chunk that held byte end - 1
  void decide(State& state, const Callback& on_message);
  void feed(State& state, const SerialChunk& chunk, const Callback& on_message);
  std::optional<SerialProtocol> fallback_;
  std::size_t guess_bytes_;
  std::vector<State> states_;  // at most kMaxLinks: a linear search is fine
  Unlisted unlisted_;
};

}  // namespace saul::host
