// The decoded messages of a serial byte capture (our serial log, sigrok/PulseView UART exports) as MCAP channels,
// for Foxglove, Lichtblick and PlotJuggler, as mcap_signals.hpp does for a CAN capture: each link's bytes go
// through its protocol's streaming decoder (SerialCaptureDecoder, as `saulctl decode` does), and each message kind
// gets a channel of its own with a JSON Schema (units in the descriptions); a message is exactly the "message"
// object that `saulctl decode --json` prints for it (json_line(to_json())), at the time of the chunk that
// completed it (log time in ns; 0 for a chunk without a time, as decode prints it).
//
// Topics (docs/captures.md lists them):
//   /serial/<protocol>/<message>   "/serial/interboard/state", "/serial/crsf/rc_channels", "/serial/pride/vcu_command"
//   /serial/crsf/undecoded         CRSF frames with a good CRC that did not decode (decode --json's "error" objects)
//   /serial/bytes                  every chunk's bytes as captured: {"link","protocol","data" (hex),"uart_errors"}
// A second link of the same protocol in one capture (both directions of a tap) gets "/serial/<protocol>_2/...", a
// third "_3", in order of appearance; every channel's metadata names its link, protocol and baud rate.
// At the end, one Metadata record "serial_link" per link: its name, protocol (and whether it was guessed), baud
// rate and format when the name says them, and the decoder's counters (decode's "frames, crc errors, ..." line).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saul::host {

inline constexpr std::string_view kMcapSerialBytesTopic = "/serial/bytes";

/// "/serial/interboard/state"; nth_link_of_protocol (from 1) > 1 adds "_N" to the protocol.
std::string mcap_serial_topic(SerialProtocol protocol, std::size_t nth_link_of_protocol, std::string_view kind);
/// The JSON Schema of to_json(message): from the message's signal description (CRSF adds its address), or the
/// undecoded CRSF frame's four members for a decode error.
std::string mcap_serial_json_schema(const SerialMessage& message);
/// The baud rate and the frame format a link's name says: "serial:/dev/ttyUSB0@460800:8N1" -> 460800, "8N1";
/// nothing for names that do not ("uart-1").
struct LinkLine {
  std::optional<std::uint32_t> baud;
  std::string format;
};
LinkLine link_line_settings(std::string_view link);

/// Writes a serial capture's chunks and decoded messages into an McapWriter.
class McapSerialChannels {
 public:
  /// `fallback`: the protocol of links whose chunks name none (sigrok exports; --protocol), else guessed.
  McapSerialChannels(McapWriter& out, std::optional<SerialProtocol> fallback);
  /// One chunk: its bytes on /serial/bytes, then the messages it completes.
  void add(const SerialChunk& chunk);
  /// End of the capture: the messages still held back, then a "serial_link" Metadata record per link.
  void finish();
  /// Messages written on the decoded channels (undecoded CRSF frames included).
  [[nodiscard]] std::uint64_t messages() const noexcept { return messages_; }
  [[nodiscard]] const SerialCaptureDecoder& decoder() const noexcept { return decoder_; }

 private:
  void on_message(const SerialChunk& chunk, SerialProtocol protocol, const SerialMessage& message);
  McapWriter& out_;
  SerialCaptureDecoder decoder_;
  SerialCaptureDecoder::Callback callback_;
  std::uint16_t bytes_channel_ = 0;
  std::map<std::pair<SerialProtocol, std::string>, std::uint16_t> schemas_;  ///< (protocol, kind) -> schema id
  std::map<std::pair<std::string, std::string>, std::uint16_t> channels_;    ///< (link, kind) -> channel id
  std::map<std::string, std::size_t> nth_link_;                              ///< link -> its number in its protocol
  std::map<SerialProtocol, std::size_t> links_of_;                           ///< links seen per protocol
  std::uint64_t messages_ = 0;
};

/// A serial capture as an MCAP file (SerialCaptureWriter): what `saulctl record -o run.mcap` writes for a serial
/// link and `saulctl convert run.serial run.mcap` for a serial capture. A Metadata record "saulctl" holds `metadata`
/// (when any); each chunk goes to McapSerialChannels; flush() closes the MCAP chunk and puts it in the file (a
/// recorder's crash loses at most what came after the last flush); close() writes the messages still held back,
/// the "serial_link" records and the summary.
class McapSerialWriter final : public SerialCaptureWriter {
 public:
  McapSerialWriter(std::ostream& out, McapWriterOptions options, const McapMap& metadata,
                   std::optional<SerialProtocol> fallback = std::nullopt);
  void write(const SerialChunk& chunk) override;
  void flush() override { mcap_.flush(); }
  void close() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::mcap; }
  [[nodiscard]] const McapSerialChannels& channels() const noexcept { return channels_; }

 private:
  McapWriter mcap_;
  McapSerialChannels channels_;
  bool closed_ = false;
};

}  // namespace saul::host
