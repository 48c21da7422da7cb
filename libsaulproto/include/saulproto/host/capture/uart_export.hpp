// What a logic analyser's UART decoder writes, read back as bytes: sigrok's "uart" protocol decoder, run by
// sigrok-cli (0.7.2 checked, on VCDs made by captures/make_uart_vcd.py) or by PulseView (formats from its source):
//  sigrok: one annotation per line ("uart-1: AA", with sample numbers "1023-1195 uart-1: AA", PulseView's export
//    "1023-1195 UART: RX: AA");
//  sigrok_json: sigrok-cli --protocol-decoder-jsontrace, one event per line:
//    {"ph": "B", "ts": 226.000000, "pid": "uart-1", "tid": "RX", "name": "FE"},   (ts in microseconds)
//  pulseview_csv: PulseView's decoder table saved as CSV (both of its styles):
//    "Sample","Time","Decoder","Ann Row","Ann Class","Value" / "1023","102.300 µs","UART","RX","RX data","AA"
// A byte is an annotation whose text is two hex digits (or, where the file names classes, of class "RX data"/"TX
// data"). Parity, frame and break annotations set uart_error bits on the byte just before them when within 2.5 bit
// times of its end (or when there are no sample numbers), else on a chunk of their own with no bytes; everything
// else is ignored. Each byte is one SerialChunk: its link is the decoder instance plus the row when known
// ("uart-1:RX", spaces as '_'), its time the annotation's start.
#pragma once

#include <cstdint>
#include <istream>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "saulproto/host/capture/serial_capture.hpp"

namespace saul::host {

/// Parses a PulseView time ("102.300 µs", "1.023 ms", "0.000 s", "-5 ns", "1:02.345", "1:00:02.345") into ns.
std::optional<std::int64_t> parse_pulseview_time(std::string_view text) noexcept;

/// Splits one CSV line of PulseView's table into fields: "quoted" fields with "" escapes, or unquoted fields
/// with "\," escapes (its two save styles). Returns false on an unterminated quote.
bool split_pulseview_csv(std::string_view line, std::vector<std::string>& fields);

/// A reader of `format` (sigrok, sigrok_json or pulseview_csv) over a stream the caller keeps alive.
std::unique_ptr<SerialCaptureReader> make_uart_export_reader(std::istream& in, CaptureFormat format,
                                                             const SerialReadOptions& options);

}  // namespace saul::host
