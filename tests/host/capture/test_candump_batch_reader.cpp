// CandumpBatchReader (convert's reader of plain candump files) against CandumpReader: the same frames, interfaces
// and corrupt lines (with their line numbers), in the same order, over more than one batch, with corrupt lines
// first, between frames and last, and a line too long to hold (reported at the same line, in the scanner's words).
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/candump_batch_reader.hpp"

using namespace saul;
using namespace saul::host;

namespace {

std::vector<std::string> events(CaptureReader& r) {
  std::vector<std::string> out;
  for (CaptureReader::Status st; (st = r.next()) != CaptureReader::Status::end;) {
    if (st == CaptureReader::Status::corrupt) {
      out.push_back("! " + format_capture_error("f", r.error()));
    } else {
      const CanFrame& f = r.frame();
      std::string data;
      for (auto b : f.payload()) data += std::to_string(b) + ",";
      out.push_back(std::to_string(f.id) + (f.extended ? "x" : "") + (f.remote ? "r" : "") + (f.error ? "e" : "") +
                    " " + std::to_string(f.dlc) + " " + data + " " + std::string(r.interface()) + " " +
                    std::to_string(f.timestamp_ns.value_or(0)));
    }
  }
  return out;
}

}  // namespace

TEST_CASE("candump batch reader: CandumpReader's frames, interfaces and corrupt lines, in order") {
  std::string log = "(1700000000.000001) can0 300#zz\n";  // corrupt first
  for (int i = 0; i < 9000; ++i) {  // more than one batch (4096 frames)
    log += "(1700000000." + std::to_string(100000 + i) + ") can" + std::to_string(i % 3) + " " +
           (i % 2 ? "1ABCDEF0#1122" : "300#E8030CFE") + "\n";
    if (i % 1000 == 7) log += "(1700000000.5) can0 12345#00\n";                   // corrupt between frames
    if (i == 4095) log += "(1700000000.6) can0 300#" + std::string(70000, '0') + "\n";  // too long
    if (i == 5000) log += "(1700000000.7) can0 301#R\n(1700000000.8) can0 20000080#0000000000000000\n";
  }
  log += "(1700000002.000000) vcan0 301#0\n";  // corrupt last
  char name[] = "/tmp/saul_batch_reader_XXXXXX";
  const int fd = mkstemp(name);
  REQUIRE(fd >= 0);
  REQUIRE(::write(fd, log.data(), log.size()) == static_cast<ssize_t>(log.size()));
  ::close(fd);
  auto batch = CandumpBatchReader::open(name);
  REQUIRE(batch);
  std::istringstream in(log);
  CandumpReader lines(in);
  const auto want = events(lines);
  const auto got = events(*batch);
  std::remove(name);
  CHECK(want.size() > 9000);
  REQUIRE(got.size() == want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    INFO(i);
    if (got[i].find("line longer than 65536 bytes") != std::string::npos) {
      // The one known difference (candump_scan.hpp): a line too long to hold is refused unread, at the same line.
      const auto line_of = [](const std::string& e) { return e.substr(0, e.find(':', 4)); };  // "! f:4103"
      CHECK(line_of(got[i]) == line_of(want[i]));
      continue;
    }
    CHECK(got[i] == want[i]);
  }
  CHECK(batch->bytes_read() == log.size());
  CHECK(batch->bytes_total() == log.size());
}

TEST_CASE("candump batch reader: nothing for a file that is no plain candump log") {
  char name[] = "/tmp/saul_batch_reader_XXXXXX";
  const int fd = mkstemp(name);
  REQUIRE(fd >= 0);
  const std::string text = "time,id,data\n1,2,3\n";
  REQUIRE(::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()));
  ::close(fd);
  CHECK_FALSE(CandumpBatchReader::open(name));
  std::remove(name);
  CHECK_FALSE(CandumpBatchReader::open("/nonexistent/run.log"));
}
