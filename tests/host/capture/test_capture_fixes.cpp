// Bugs found with other tools' files (issue 16), one test each: candump's raw-DLC suffix, ASC's DLC 9..15 and
// classic frames on CANFD lines (log2asc -f), pcapng Simple Packet Blocks, error frames in pcap, interface names with
// white space, another tool's text log named .log; and content detection of the new formats, --input-format,
// and a broken compressed file reported as a corrupt record; a log through a pipe path (a process substitution)
// read once, not opened again for its text.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "formats_test.hpp"
#include "saulproto/host/capture/asc.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/interface_index.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "saulproto/host/capture/trc.hpp"
#include "saulproto/host/capture/serial_capture.hpp"

using namespace saul;
using namespace saul::host;

namespace {

using capture_test::messages;
using capture_test::read_all;
using capture_test::Read;
using capture_test::TempDir;

Read read(const std::string& bytes, CaptureFormat format) { return capture_test::read_text(bytes, format); }

std::optional<CaptureFormat> detect(std::string_view text) {
  return detect_capture_format(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

void le32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s += static_cast<char>(v >> (8 * i));
}
/// A SocketCAN packet as pcap and pcapng hold it: id 0x300 (big-endian), DLC 2, data 11 22.
const std::string kPacket300("\x00\x00\x03\x00\x02\x00\x00\x00\x11\x22\x00\x00\x00\x00\x00\x00", 16);

/// A little-endian pcapng Section Header Block (version 1.0, section length unknown).
void pcapng_section(std::string& f) {
  le32(f, 0x0A0D0D0A);
  le32(f, 28);
  le32(f, 0x1A2B3C4D);
  f += std::string("\x01\x00\x00\x00", 4);
  f += std::string(8, '\xFF');
  le32(f, 28);
}

}  // namespace

TEST_CASE("candump: the raw-DLC suffix can-utils writes since 2020.12") {
  CandumpLine line;
  CandumpError error;
  REQUIRE(parse_candump_line("(1700000000.000000) can0 3FF#55AA010203040506_D", line, error));
  CHECK((line.frame.id == 0x3FF && line.frame.dlc == 8 && line.frame.data[7] == 0x06));
  REQUIRE(parse_candump_line("(1700000000.000000) can0 123#R8_D", line, error));
  CHECK((line.frame.remote && line.frame.dlc == 8));
  CHECK(!parse_candump_line("(1700000000.000000) can0 123#1122_D", line, error));
  CHECK(error.message == "a raw DLC suffix needs 8 data bytes (or R8)");
  CHECK(!parse_candump_line("(1700000000.000000) can0 3FF#55AA010203040506_8", line, error));
  CHECK(error.message == "raw DLC suffix must be _9 to _F (after 8 data bytes)");
}

TEST_CASE("ASC: a classic DLC of 9..15 and CANFD lines that carry classic frames") {
  const std::string header = "date Tue Nov 14 22:13:20 2023\nbase hex  timestamps absolute\nno internal events logged\n";
  // CANoe 12 writes the DLC of a classic frame as it was on the wire: D = 13, 8 bytes follow
  const Read dlc = read(header + "   0.001000 1  3FF             Tx   d D 55 AA 01 02 03 04 05 06\n", CaptureFormat::asc);
  REQUIRE(dlc.frames.size() == 1);
  CHECK((dlc.frames[0].dlc == 8 && dlc.frames[0].data[7] == 0x06));
  // `log2asc -f -I t.log can0` (can-utils 2020.11) for 344x 00 00 05 DC, 123#R4, 7FF#1122, an FD frame with BRS;
  // then a line with a symbolic name, as CANoe writes them
  const Read fd = read(header +
                           "   0.000000 CANFD   1 Rx        344x                                  0 0 4  4 00 00 05 DC   130000  130        0 0 0 0 0 0\n"
                           "   0.001250 CANFD   1 Rx        123                                   0 0 4  0   130000  130       10 0 0 0 0 0\n"
                           "   0.002000 CANFD   1 Rx        7FF                                   0 0 2  2 11 22   130000  130        0 0 0 0 0 0\n"
                           "   0.003000 CANFD   1 Rx        123                                   1 0 3  3 11 22 33   130000  130     3000 0 0 0 0 0\n"
                           "   0.004000 CANFD   2 Tx        300  velocity_cmd  0 0 4  4 E8 03 0C FE   130000  130        0 0 0 0 0 0\n",
                       CaptureFormat::asc);
  REQUIRE(fd.frames.size() == 4);
  CHECK((fd.frames[0].id == 0x344 && fd.frames[0].extended && fd.frames[0].dlc == 4 && fd.frames[0].data[3] == 0xDC));
  CHECK((fd.frames[1].remote && fd.frames[1].dlc == 4));
  CHECK((fd.frames[2].id == 0x7FF && fd.frames[2].dlc == 2));
  CHECK((fd.frames[3].id == 0x300 && fd.frames[3].data[0] == 0xE8));
  CHECK(fd.names == std::vector<std::string>{"can0", "can0", "can0", "can1"});
  CHECK(messages(fd) == std::vector<std::string>{"CAN FD frame: the robot's bus is classic CAN, FD is not supported"});
}

TEST_CASE("pcapng: Simple Packet Blocks are read (interface 0, no timestamp)") {
  std::string f;
  pcapng_section(f);
  le32(f, 1);  // IDB: linktype 227, snaplen 0, if_name "can7"
  le32(f, 28);
  le32(f, 227);
  le32(f, 0);
  f += std::string("\x02\x00\x04\x00" "can7", 8);
  le32(f, 28);
  le32(f, 3);  // SPB: original length, then the packet
  le32(f, 32);
  le32(f, 16);
  f += kPacket300;
  le32(f, 32);
  le32(f, 3);  // a length past its block
  le32(f, 32);
  le32(f, 40);
  f += kPacket300;
  le32(f, 32);
  const Read r = read(f, CaptureFormat::pcapng);
  REQUIRE(r.frames.size() == 1);
  CHECK((r.frames[0].id == 0x300 && r.frames[0].dlc == 2 && r.frames[0].data[1] == 0x22));
  CHECK(!r.frames[0].timestamp_ns);
  CHECK(r.names[0] == "can7");
  CHECK(messages(r) == std::vector<std::string>{"packet length 40 runs past the end of its simple packet block"});
}

TEST_CASE("pcap: an error frame carries 8 bytes, as the kernel sends it (Wireshark marks 0 malformed)") {
  CanFrame e;
  e.error = true;
  e.id = 0x004;
  e.dlc = 0;  // whatever the source said
  const auto p = encode_socketcan_packet(e);
  CHECK(p == std::array<std::uint8_t, 16>{0x20, 0x00, 0x00, 0x04, 0x08, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  e.dlc = 8;
  e.data = {0, 0x04, 0, 0, 0, 0, 0, 0};
  CHECK(encode_socketcan_packet(e)[9] == 0x04);
}

TEST_CASE("candump: an interface name with white space (text2pcap's pcapng) is one word") {
  CanFrame f;
  f.id = 0x300;
  f.dlc = 2;
  f.data = {0x11, 0x22};
  f.timestamp_ns = 1'700'000'000'000'000'000ULL;
  CHECK(format_candump_line(f, "Fake IF, text2pcap") == "(1700000000.000000) Fake_IF,_text2pcap 300#1122");
  std::ostringstream out;
  CandumpWriter w(out);
  w.write(f, "Fake IF, text2pcap");  // used to throw and abort the whole conversion
  CHECK(out.str() == "(1700000000.000000) Fake_IF,_text2pcap 300#1122\n");
  CopyStats stats;
  stats.interfaces = {"Fake IF, text2pcap"};
  CHECK(conversion_losses(stats, CaptureFormat::candump) ==
        std::vector<std::string>{"candump writes white space in interface names as '_': 'Fake IF, text2pcap' reads "
                                 "back as 'Fake_IF,_text2pcap'"});
}

TEST_CASE("a .log that is another tool's text log is refused, not read as an empty capture") {
  TempDir dir("fixes");
  const auto busmaster = dir.write("bm.log",
                                   "***BUSMASTER Ver 3.2.2***\n***PROTOCOL CAN***\n***[START LOGGING SESSION]***\n"
                                   "10:39:51:0105 Rx 1 0x0C1 s 8 00 00 00 00 00 00 00 00\n");
  try {
    (void)open_capture_reader(busmaster);
    FAIL("opened");
  } catch (const CaptureOpenError& e) {
    CHECK(std::string(e.what()).find("is not a candump log: it is a BusMaster log") != std::string::npos);
  }
  const auto microchip = dir.write("mc.log", "Time(ms),ID,DLC,Data\n12.5,0x300,4,E8 03 0C FE\n");
  CHECK_THROWS_WITH(open_capture_reader(microchip), Catch::Contains("whose first line is 'Time(ms),ID,DLC,Data'"));
  // forced, it reads as canplayer would: no frame
  auto forced = open_capture_reader(busmaster, CaptureFormat::candump);
  CHECK(read_all(*forced).frames.empty());
  auto empty = open_capture_reader(dir.write("empty.log", ""));  // an empty recording is still a capture
  CHECK(read_all(*empty).frames.empty());
}

TEST_CASE("content detection of BLF, TRC and both CSVs; --input-format overrides it") {
  CHECK(detect(std::string("LOGG\x90\0\0\0", 8)) == CaptureFormat::blf);
  CHECK(detect(";$FILEVERSION=1.1\r\n;$STARTTIME=45000.5\r\n") == CaptureFormat::trc);
  CHECK(detect(";##########\n;   Start time: 12.03.2015\n     1)      1841  0001    8  00\n") == CaptureFormat::trc);
  CHECK(detect("timestamp,arbitration_id,extended,remote,error,dlc,data\n") == CaptureFormat::csv);
  CHECK(detect("Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2\n") == CaptureFormat::gvret_csv);
  CHECK(detect("TIME STAMP,ID,EXTENDED,BUS,LEN,D1\n") == CaptureFormat::gvret_csv);
  CHECK(detect("Sample,Time,Decoder,Ann Row\n") == CaptureFormat::pulseview_csv);
  CHECK(capture_format_from_extension("x.BLF") == CaptureFormat::blf);
  CHECK(capture_format_from_extension("x.trc") == CaptureFormat::trc);
  CHECK(capture_format_from_extension("x.log.gz") == std::nullopt);
  CHECK(capture_format_from_name("gvret-csv") == CaptureFormat::gvret_csv);

  TempDir dir("fixes");
  const auto asc = dir.write("x.asc", "date Tue Nov 14 22:13:20 2023\n   0.001000 1  300  Rx   d 1 01\n");
  SerialReadOptions options;
  options.format = CaptureFormat::candump;
  const OpenedCapture opened = open_capture(asc, options);
  CHECK(opened.format == CaptureFormat::candump);  // forced: its lines are comments to candump
  REQUIRE(opened.frames);
  CHECK(read_all(*opened.frames).frames.empty());
  CHECK(open_capture(asc).format == CaptureFormat::asc);
}

TEST_CASE("a broken compressed file ends with a corrupt record saying so") {
  TempDir dir("fixes");
  const auto path = (dir.path / "run.log.gz").string();
  {
    auto w = open_capture_writer(path);
    CanFrame f;
    f.id = 0x300;
    f.dlc = 1;
    for (std::uint8_t i = 0; i < 200; ++i) {
      f.data[0] = i;
      f.timestamp_ns = 1'700'000'000'000'000'000ULL + i * 1000ULL;
      w->write(f, "can0");
    }
    w->close();
  }
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto cut = dir.write("cut.gz", bytes.substr(0, bytes.size() / 2));
  auto r = open_capture_reader(cut);
  CHECK(r->format() == CaptureFormat::candump);
  const Read got = read_all(*r);
  CHECK(!got.frames.empty());
  REQUIRE(!got.errors.empty());
  CHECK(got.errors.back().message == "the gzip file ends before its end marker (truncated?)");
  CHECK(got.errors.back().recovery == Recovery::stop);
}

namespace {
/// Reads `path` through a pipe opened by its /dev/fd name, as `saulctl decode <(cat path)` does: `use` gets that
/// name while a thread writes the file's bytes into the pipe.
template <class Use>
void through_pipe(const std::string& path, Use&& use) {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::thread writer([&] {
    for (std::size_t at = 0; at < bytes.size();) {
      const ssize_t n = ::write(fds[1], bytes.data() + at, bytes.size() - at);
      if (n <= 0) break;
      at += static_cast<std::size_t>(n);
    }
    ::close(fds[1]);
  });
  use("/dev/fd/" + std::to_string(fds[0]));
  ::close(fds[0]);  // a writer still blocked (the test read less) then fails and ends
  writer.join();
}
std::string all_text(CaptureText& text) {
  std::string got;
  char buf[1000];  // small reads: the replayed head and the rest in many pieces
  for (std::size_t n; (n = text.read(buf, sizeof buf)) > 0;) got.append(buf, n);
  return got;
}
}  // namespace

TEST_CASE("a candump log through a pipe path is read once: take_capture_text gives all of it, compressed or not") {
  // decode and stats once opened the path again for the text, after the first look at it had taken its first bytes:
  // a process substitution lost 8 KiB of lines, and a compressed one could not be read at all
  TempDir dir("fixes");
  std::string plain;
  for (int i = 0; i < 2000; ++i)  // ~70 KB: far more than the first look reads
    plain += fmt::format("(1700000000.{:06}) can0 300#{:08X}\n", i, i * 7919U);
  const auto log = dir.write("run.log", plain);
  const auto gz = (dir.path / "run.log.gz").string();
  {
    auto w = open_capture_writer(gz, CaptureFormat::candump);  // the same lines, gzipped
    auto r = open_capture_reader(log);
    copy_frames(r, *w, {});
    w->close();
  }
  for (const auto& path : {log, gz}) {
    INFO(path);
    through_pipe(path, [&](const std::string& name) {
      OpenedCapture opened = open_capture(name);
      CHECK(opened.compressed == (path == gz));
      REQUIRE(opened.frames);
      const auto text = take_capture_text(opened.frames);
      REQUIRE(text);
      CHECK(!opened.frames);  // given up for the text
      CHECK(text->compressed() == (path == gz));
      CHECK(all_text(*text) == plain);
    });
  }
  SECTION("a reader something has read from is kept, and reads on") {
    through_pipe(log, [&](const std::string& name) {
      OpenedCapture opened = open_capture(name);
      FrameBatch first;
      REQUIRE(opened.frames->next_batch(first));
      REQUIRE(!first.frames.empty());
      CHECK(take_capture_text(opened.frames) == nullptr);
      REQUIRE(opened.frames);
      CHECK(first.frames.size() + read_all(*opened.frames).frames.size() == 2000);
    });
  }
  SECTION("a capture that is not candump text keeps its reader") {
    const auto pcap = (dir.path / "run.pcap").string();
    {
      auto w = open_capture_writer(pcap);
      auto r = open_capture_reader(log);
      copy_frames(r, *w, {});
      w->close();
    }
    OpenedCapture opened = open_capture(pcap);
    CHECK(take_capture_text(opened.frames) == nullptr);
    REQUIRE(opened.frames);
    CHECK(read_all(*opened.frames).frames.size() == 2000);
  }
}

TEST_CASE("InterfaceIndex numbers names as a walk through the names seen does, and holds at most max") {
  // the writers and copy_frames() walked their names for every frame: a log of a million names took 20 minutes
  std::mt19937 rng(1128);
  std::vector<std::string> walked;  // the oracle: numbers by a walk
  InterfaceIndex index;
  for (int i = 0; i < 20000; ++i) {
    // runs of one name, names coming back, and now and then a new one
    const std::string name = rng() % 8 == 0 ? fmt::format("can{}", rng() % 3000) : fmt::format("vcan{}", rng() % 4);
    std::size_t n = 0;
    while (n < walked.size() && walked[n] != name) ++n;
    const bool fits = n < walked.size() || walked.size() < 1000;
    if (n == walked.size() && fits) walked.push_back(name);
    const auto got = index.find_or_add(name, 1000);
    REQUIRE(got.has_value() == fits);
    if (fits) REQUIRE(*got == n);
  }
  CHECK(index.names() == walked);
  CHECK(walked.size() == 1000);  // the cap was reached, and names beyond it were refused, not added
}

TEST_CASE("a log of more interfaces than a format numbers is refused by its writer; copy_frames lists the first") {
  std::string text;
  for (int i = 0; i < 1100; ++i) text += fmt::format("(1700000000.{:06}) if{} 300#00\n", i, i);
  std::istringstream in(text);
  std::unique_ptr<CaptureReader> reader = std::make_unique<CandumpReader>(in);
  std::ostringstream out;
  AscWriter asc(out);
  CHECK_THROWS_WITH(copy_frames(reader, asc, {}), "ASC: more than 255 interfaces, the channels the format numbers");

  std::istringstream again(text);
  std::unique_ptr<CaptureReader> reader2 = std::make_unique<CandumpReader>(again);
  std::ostringstream csv;
  auto writer = make_capture_writer(csv, CaptureFormat::trc);  // TRC numbers buses too: 255
  CHECK_THROWS_AS(copy_frames(reader2, *writer, {}), std::invalid_argument);

  std::istringstream third(text);
  std::unique_ptr<CaptureReader> reader3 = std::make_unique<CandumpReader>(third);
  std::ostringstream log;
  CandumpWriter candump(log);
  const CopyStats stats = copy_frames(reader3, candump, {});
  CHECK(stats.frames == 1100);
  CHECK(stats.interfaces.size() == CopyStats::kListed);
  CHECK(stats.interfaces.front() == "if0");
  CHECK(stats.more_interfaces);
  const auto notes = conversion_losses(stats, CaptureFormat::asc);
  REQUIRE(notes.size() == 1);
  CHECK(notes[0].ends_with(", and those of the interfaces after the first 1024"));
}

TEST_CASE("pcapng: a section declares at most kPcapngMaxInterfaces interfaces; the reader refuses more") {
  // each is a name held while reading: a file of millions of declarations must not take memory without end
  std::string f;
  pcapng_section(f);
  for (std::size_t i = 0; i <= kPcapngMaxInterfaces; ++i) {  // one more than read: IDBs of linktype 227, no name
    le32(f, 1);
    le32(f, 20);
    le32(f, 227);
    le32(f, 0);
    le32(f, 20);
  }
  for (std::uint32_t id : {static_cast<std::uint32_t>(kPcapngMaxInterfaces),
                           static_cast<std::uint32_t>(kPcapngMaxInterfaces - 1)}) {
    le32(f, 6);  // EPB on the refused interface, then on the last one read
    le32(f, 48);
    le32(f, id);
    le32(f, 0);
    le32(f, 1000);
    le32(f, 16);
    le32(f, 16);
    f += kPacket300;
    le32(f, 48);
  }
  const Read r = read(f, CaptureFormat::pcapng);
  REQUIRE(r.frames.size() == 1);
  CHECK(r.names[0] == fmt::format("can{}", kPcapngMaxInterfaces - 1));
  REQUIRE(r.errors.size() == 2);
  CHECK(r.errors[0].message.starts_with("more than 65536 interfaces in one section"));
  CHECK(r.errors[1].message == "packet of interface 65536, which no interface description block declared");
}
