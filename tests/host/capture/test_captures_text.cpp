// The text formats against lines from the reference tools (log2asc 2020.11, python-can 4.1.0, candump -l):
// Vector ASC's variants (hex/dec, absolute/relative times, dates, trigger blocks, events) and the writer's layout,
// candump through the common interface, and corrupt lines reported with line and column.
#include <catch2/catch.hpp>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/asc.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "test_captures.hpp"

using saul::CanFrame;
using namespace saul::host;
using namespace capture_test;

// ---- Vector ASC ----

TEST_CASE("asc: log2asc 2020.11 output of protocols.md 6.3 parses, the CAN FD line is refused with its line") {
  const std::string log2asc =
      "date Tue Nov 14 22:13:20 2023\n"
      "base hex  timestamps absolute\n"
      "no internal events logged\n"
      "   0.000000 1  344x            Rx   d 4 00 00 05 DC\n"
      "   0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
      "   0.002500 1  123             Rx   r 0\n"
      "   0.003000 1  123             Rx   r 4\n"
      "   0.004000 1  7FF             Rx   d 2 11 22\n"
      "   0.005000 1  ErrorFrame\n"
      "   0.006000 CANFD   1 Rx        123                                   1 0 3  3 11 22 33   130000  130     "
      "3000 0 0 0 0 0\n";
  CHECK(detect_capture_format(as_bytes(log2asc)) == CaptureFormat::asc);
  const Read r = read_text(log2asc, CaptureFormat::asc);
  const std::uint64_t t0 = 1700000000 * kSec;  // the date line, read as UTC
  REQUIRE(r.frames.size() == 6);
  CHECK(r.frames[0] == kDocFrames[0]);
  CHECK(r.frames[1] == kDocFrames[1]);
  CHECK(r.frames[2] == remote(0x123, false, 0, t0 + 2'500'000));
  CHECK(r.frames[3] == remote(0x123, false, 4, t0 + 3'000'000));
  CHECK(r.frames[4] == kDocFrames[2]);
  CHECK(r.frames[5].error);
  CHECK(r.frames[5].id == 0x080);
  CHECK(*r.frames[5].timestamp_ns == t0 + 5'000'000);
  CHECK(r.names[0] == "can0");
  REQUIRE(r.errors.size() == 1);
  CHECK(r.errors[0].position == 10);
  CHECK(r.errors[0].column == 12);
  CHECK(r.errors[0].message.find("CAN FD") != std::string::npos);
}

TEST_CASE("asc: python-can 4.1.0 writer output parses (AM/PM date, trigger block, events)") {
  const std::string python_can =
      "date Sun Nov 22 06:54:33.675 PM 2026\n"  // when the file was made: the trigger block date wins
      "base hex  timestamps absolute\n"
      "internal events logged\n"
      "Begin Triggerblock Tue Nov 14 10:13:20.000 PM 2023\n"
      " 0.000000 Start of measurement\n"
      " 0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
      " 0.002000 1  123             Rx   r 4 \n"
      " 0.003000 1  ErrorFrame\n"
      " 0.004000 2  7FF             Rx   d 0 \n"
      "End TriggerBlock\n";
  std::istringstream in(python_can);
  AscReader reader(in);
  const Read r = read_all(reader);
  CHECK(reader.wall_clock());
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 4);
  CHECK(r.frames[0] == kDocFrames[1]);
  CHECK(r.frames[1] == remote(0x123, false, 4, 1700000000 * kSec + 2'000'000));
  CHECK(r.frames[2].error);
  CHECK(r.frames[3] == make(0x7FF, false, {}, 1700000000 * kSec + 4'000'000));
  CHECK(r.names[3] == "can1");
}

TEST_CASE("asc: a UTF-8 byte-order mark before the date line is skipped, as in the other text formats") {
  // an editor on Windows saves one; the reader took it for part of the first word and lost the date
  const std::string text =
      "\xEF\xBB\xBF" "date Tue Nov 14 22:13:20 2023\n"
      "base hex  timestamps absolute\n"
      "   0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n";
  CHECK(detect_capture_format(as_bytes(text)) == CaptureFormat::asc);
  std::istringstream in(text);
  AscReader reader(in);
  const Read r = read_all(reader);
  CHECK(reader.wall_clock());
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 1);
  CHECK(r.frames[0] == kDocFrames[1]);
}

TEST_CASE("asc: base dec, timestamps relative (each time counted from the previous frame), no date") {
  const std::string text =
      "base dec  timestamps relative\n"
      "no internal events logged\n"
      "0.5 2  836x Rx d 4 0 0 5 220\n"
      "0.25 2  2047 Tx d 2 17 34 Length = 0 BitCount = 0 ID = 2047\n"
      "0.25 1  Statistic: D 0 R 0 XD 0 XR 0 E 0 O 0 B 0.00%\n"
      "0.25 1  291 TxRq d 0\n";
  std::istringstream in(text);
  AscReader reader(in);
  const Read r = read_all(reader);
  CHECK_FALSE(reader.wall_clock());
  CHECK(r.errors.empty());
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[0] == make(0x344, true, {0x00, 0x00, 0x05, 0xDC}, 500'000'000));
  CHECK(r.frames[1] == make(0x7FF, false, {0x11, 0x22}, 750'000'000));
  CHECK(r.names[0] == "can1");
}

TEST_CASE("asc: corrupt lines are reported with line and column, the next lines still read") {
  const std::string text =
      "date Tue Nov 14 22:13:20 2023\n"              // 1
      "base hex  timestamps absolute\n"              // 2
      "   0.000000 1  3G4             Rx   d 1 00\n"  // 3  id not hex
      "   0.000100 1  123             Rx   d 4 01 02\n"  // 4  2 of 4 bytes
      "   0.000200 1  123             Rx   d 9 01\n"  // 5  DLC 9: 8 bytes on classic CAN, 1 found
      "   0.000300 1  800             Rx   d 0\n"     // 6  11-bit id too big
      "   0.000400 1  123             Rx   q 0\n"     // 7  neither d nor r
      "   0.000500 1  124\n"                          // 8  cut short
      "hello\n"                                       // 9  not ASC
      "   1.5x 1  123 Rx d 0\n"                       // 10 bad time
      "   0.000900 1  7FF             Rx   d 1 AA\n";  // 11 good
  const Read r = read_text(text, CaptureFormat::asc);
  REQUIRE(r.frames.size() == 1);
  CHECK(r.frames[0].data[0] == 0xAA);
  REQUIRE(r.errors.size() == 8);
  const std::vector<std::pair<std::uint64_t, std::size_t>> where = {{3, 15}, {4, 45}, {5, 42}, {6, 15},
                                                                    {7, 36}, {8, 18}, {9, 0},  {10, 3}};
  for (std::size_t i = 0; i < where.size(); ++i) {
    INFO("error " << i << ": " << r.errors[i].message);
    CHECK(r.errors[i].position == where[i].first);
    CHECK(r.errors[i].column == where[i].second);
    CHECK(r.errors[i].recovery == Recovery::next_line);
  }
  CHECK(format_capture_error("v.asc", r.errors[0]) == "v.asc:3:16: id is not hexadecimal (line skipped)");
}

TEST_CASE("asc: dates") {
  CHECK(parse_asc_date("Tue Nov 14 22:13:20 2023") == 1700000000 * kSec);
  CHECK(parse_asc_date("Tue Nov 14 10:13:20.250 pm 2023") == 1700000000 * kSec + 250'000'000);
  CHECK(parse_asc_date("Nov 14 12:00:00 AM 2023") == (1700000000ULL - 22 * 3600 - 13 * 60 - 20) * kSec);
  CHECK(parse_asc_date("Do Mär 07 08:00:00 2024") == 1709798400 * kSec);
  CHECK(parse_asc_date("Thu Feb 29 00:00:00 2024") == 1709164800 * kSec);
  CHECK_FALSE(parse_asc_date("yesterday"));
  CHECK_FALSE(parse_asc_date("Tue Nov 14 25:13:20 2023"));
  CHECK(format_asc_date(1700000000 * kSec + 999) == "Tue Nov 14 22:13:20 2023");
  CHECK(format_asc_date(1709164800 * kSec) == "Thu Feb 29 00:00:00 2024");
  CHECK(format_asc_date(0) == "Thu Jan 01 00:00:00 1970");
}

TEST_CASE("asc: the writer's lines follow log2asc's layout, times from the whole second before the first frame") {
  std::ostringstream out;
  AscWriter writer(out);
  writer.write(kDocFrames[0], "can0");
  writer.write(kDocFrames[1], "can0");
  writer.write(remote(0x123, false, 4, 1700000000 * kSec + 3'000'000), "can0");
  writer.write(error_frame(0x004, {0, 0x20}, 1700000000 * kSec + 5'000'000), "vcan7");
  writer.close();
  CHECK(out.str() ==
        "date Tue Nov 14 22:13:20 2023\n"
        "base hex  timestamps absolute\n"
        "internal events logged\n"
        "Begin Triggerblock Tue Nov 14 22:13:20 2023\n"
        "   0.000000 Start of measurement\n"
        "   0.000000 1  344x            Rx   d 4 00 00 05 DC\n"
        "   0.001250 1  938x            Rx   d 8 FF FF FB 50 00 23 00 FA\n"
        "   0.003000 1  123             Rx   r 4\n"
        "   0.005000 2  ErrorFrame\n"
        "End TriggerBlock\n");
}

// ---- candump through the common interface ----

TEST_CASE("candump: corrupt lines carry their line number and column through CaptureError") {
  const std::string text =
      "# a comment\n"
      "(1.000000) can0 123#11\n"
      "(2.0 can0 123#\n"
      "(3.000000) can0 12G#00\n"
      "(4.000000) can0 123##1\n"
      "DROPCOUNT: dropped 3 CAN frame(s) on 'can0' socket (total drops 3)\n"
      "(5.000000) can0 456#22\n";
  const Read r = read_text(text, CaptureFormat::candump);
  REQUIRE(r.frames.size() == 2);
  CHECK(r.frames[1] == make(0x456, false, {0x22}, 5 * kSec));
  REQUIRE(r.errors.size() == 3);
  CHECK(r.errors[0].position == 3);
  CHECK(r.errors[0].column == 0);
  CHECK(r.errors[1].position == 4);
  CHECK(r.errors[1].column == 18);
  CHECK(r.errors[2].position == 5);
  CHECK(r.errors[2].message.find("CAN FD") != std::string::npos);
  CHECK(format_capture_error("g.log", r.errors[1]) == "g.log:4:19: id is not hexadecimal (line skipped)");
}

TEST_CASE("candump writer: the lines candump -l writes") {
  std::ostringstream out;
  CandumpWriter writer(out);
  writer.write(kDocFrames[0], "can0");
  writer.write(remote(0x123, false, 4, 1700000000 * kSec + 3'000'000), "vcan1");
  writer.write(error_frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0}, 1700000000 * kSec + 5'000'000), "");
  writer.close();
  CHECK(out.str() ==
        "(1700000000.000000) can0 00000344#000005DC\n"
        "(1700000000.003000) vcan1 123#R4\n"
        "(1700000000.005000) can0 20000080#0000000000000000\n");
  std::ostringstream spaced;  // white space in a name would split the line: written as '_' (issue 16)
  CandumpWriter(spaced).write(kDocFrames[0], "can 0");
  CHECK(spaced.str() == "(1700000000.000000) can_0 00000344#000005DC\n");
}

