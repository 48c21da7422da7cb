// PEAK TRC: lines of every version written here by hand after PEAK's layouts (trc.hpp), the $STARTTIME day count
// against values computed with Python's decimal module, and the writer's exact lines.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>
#include <vector>

#include "formats_test.hpp"
#include "saulproto/host/capture/trc.hpp"

using namespace saul;
using namespace saul::host;

namespace {

using capture_test::located;

struct TrcRead : capture_test::Read {
  int version = 0;
};

TrcRead read(const std::string& text) {
  std::istringstream in(text);
  TrcReader r(in);
  TrcRead out;
  static_cast<capture_test::Read&>(out) = capture_test::read_all(r);
  out.version = r.version();
  return out;
}

// (Decimal("44548.6028595139") - 25569) * 86400 * 10**9 in Python: 1639837687062000960
constexpr std::uint64_t kStart44548 = 1'639'837'687'062'000'960ULL;
// 45000.5 days: 2023-03-15 12:00:00 UTC
constexpr std::uint64_t kStart45000 = 1'678'881'600'000'000'000ULL;

}  // namespace

TEST_CASE("TRC start time: days since 1899-12-30, exact to the nanosecond") {
  CHECK(parse_trc_start_time("44548.6028595139") == kStart44548);
  CHECK(parse_trc_start_time("45000.5") == kStart45000);
  CHECK(parse_trc_start_time("25569") == 0U);
  CHECK(!parse_trc_start_time("25568.9"));  // before 1970
  CHECK(!parse_trc_start_time("4x.5"));
}

TEST_CASE("TRC 1.0 and 1.1: PCAN-View's layouts") {
  const TrcRead v10 = read(
      ";##########################################################################\r\n"
      ";   Start time: 12.03.2015 14:53:28.547\r\n"
      "     1)      1841  0001    8  00 11 22 33 44 55 66 77\r\n"
      "     2)      1900  FFFFFFFF  4  00 00 00 08\r\n"
      "     3)      1950  00000344    4  00 00 05 DC\r\n");
  CHECK(v10.version == 10);
  CHECK(v10.errors.empty());
  REQUIRE(v10.frames.size() == 2);
  CHECK((v10.frames[0].id == 1 && !v10.frames[0].extended && v10.frames[0].dlc == 8));
  CHECK(*v10.frames[0].timestamp_ns == 1'841'000'000ULL);  // no $STARTTIME: offsets only
  CHECK((v10.frames[1].id == 0x344 && v10.frames[1].extended));

  const TrcRead v11 = read(
      ";$FILEVERSION=1.1\r\n;$STARTTIME=45000.5\r\n;\r\n"
      "     1)      1841.0  Rx         0300  4  E8 03 0C FE \r\n"
      "     2)      1851.3  Tx     00000344  4  00 00 05 DC \r\n"
      "     3)      1859.8  Warng  FFFFFFFF  4  00 00 00 08  BUSHEAVY \r\n"
      "     4)      1860.1  Rx         0123  4  RTR \r\n"
      "     5)      1861.0  Error  00000000  0 \r\n"
      "     6)      1862.0  Rx         0300  4  E8 03 \r\n"
      "     7)      1863.0  Fd         0300  4  E8 03 0C FE \r\n");
  CHECK(v11.version == 11);
  REQUIRE(v11.frames.size() == 4);
  CHECK(*v11.frames[0].timestamp_ns == kStart45000 + 1'841'000'000ULL);
  CHECK(*v11.frames[1].timestamp_ns == kStart45000 + 1'851'300'000ULL);
  CHECK((v11.frames[1].id == 0x344 && v11.frames[1].extended && v11.frames[1].data[3] == 0xDC));
  CHECK((v11.frames[2].remote && v11.frames[2].dlc == 4 && v11.frames[2].id == 0x123));
  CHECK((v11.frames[3].error && v11.frames[3].id == 0x080));
  CHECK(v11.names == std::vector<std::string>{"can0", "can0", "can0", "can0"});
  CHECK(located(v11) == std::vector<std::string>{"9:48 4 data bytes announced, 2 found",
                                               "10:22 unknown message type 'Fd'"});
}

TEST_CASE("TRC 1.2 and 1.3: the bus column, 1.3's reserved column") {
  const TrcRead v12 = read(";$FILEVERSION=1.2\n;$STARTTIME=45000.5\n     1)      1841.0 2  Rx         0300  2  E8 03\n");
  REQUIRE(v12.frames.size() == 1);
  CHECK(v12.names[0] == "can1");
  CHECK(v12.frames[0].dlc == 2);
  const TrcRead v13 = read(
      ";$FILEVERSION=1.3\n;$STARTTIME=44548.6028595139\n"
      "     1)        17535.4 1  Tx    00000100 -  8    00 00 00 00 00 00 00 01\n"
      "     2)        19295.4 2  Rx        0000 -  13   00 00 00 00 00 00 00 02\n"
      "     3)        19300.0 2  Error  00000000 -  0\n");
  CHECK(v13.errors.empty());
  REQUIRE(v13.frames.size() == 3);
  CHECK(*v13.frames[0].timestamp_ns == kStart44548 + 17'535'400'000ULL);
  CHECK((v13.frames[0].id == 0x100 && v13.frames[0].extended && v13.frames[0].data[7] == 1));
  CHECK((v13.frames[1].id == 0 && !v13.frames[1].extended && v13.frames[1].dlc == 8));  // DLC 13 on classic CAN
  CHECK(v13.frames[2].error);
  CHECK(v13.names == std::vector<std::string>{"can0", "can1", "can1"});
}

TEST_CASE("TRC 2.0 and 2.1: columns from $COLUMNS, message types") {
  const TrcRead v20 = read(
      ";$FILEVERSION=2.0\r\n;$STARTTIME=45000.5\r\n;$COLUMNS=N,O,T,I,d,l,D\r\n"
      "      1      1059.900 DT     0300 Rx 7  00 00 00 00 04 00 00\r\n"
      "      2      1060.000 ST          Rx    00 00 00 08\r\n"
      "      3      1298.945 DT 00000400 Tx 2  00 01\r\n"
      "      4      1323.201 FD     0400 Tx 12 00 00 00 00 00 00 00 00 00 00 00 00\r\n"
      "      5      1334.522 ER          Rx 04 00 02 00 00\r\n"
      "      6      1334.600 RR     0100 Rx 3\r\n"
      "      7      1334.700 EV          Rx    something happened\r\n");
  CHECK(v20.version == 20);
  REQUIRE(v20.frames.size() == 4);
  CHECK(*v20.frames[0].timestamp_ns == kStart45000 + 1'059'900'000ULL);
  CHECK((v20.frames[0].id == 0x300 && v20.frames[0].dlc == 7 && v20.frames[0].data[4] == 4));
  CHECK((v20.frames[1].id == 0x400 && v20.frames[1].extended));
  CHECK(*v20.frames[1].timestamp_ns == kStart45000 + 1'298'945'000ULL);
  CHECK((v20.frames[2].error && v20.frames[2].id == 0x080));
  CHECK((v20.frames[3].remote && v20.frames[3].dlc == 3));
  CHECK(located(v20) == std::vector<std::string>{"7:23 CAN FD frame: the robot's bus is classic CAN, FD is not supported"});

  // 2.1 as PEAK-Converter and python-can write it, then the same frames with the columns in another order
  const TrcRead v21 = read(
      ";$FILEVERSION=2.1\n;$STARTTIME=44548.6028595139\n;$COLUMNS=N,O,T,B,I,d,R,L,D\n"
      "      1     17535.400 DT 1  00000100 Tx -  8    00 00 00 00 00 00 00 00\n"
      "      2     17540.300 ST 1         - Rx -  4    00 00 00 08\n"
      "      3     19295.400 DT 2      07FF Tx -  2    AA BB\n");
  CHECK(v21.errors.empty());
  REQUIRE(v21.frames.size() == 2);
  CHECK(*v21.frames[1].timestamp_ns == kStart44548 + 19'295'400'000ULL);
  CHECK(v21.names == std::vector<std::string>{"can0", "can1"});
  const TrcRead moved = read(";$FILEVERSION=2.1\n;$COLUMNS=N,O,T,I,B,d,L,D\n 1 1.5 DT 07FF 2 Tx 2 AA BB\n");
  REQUIRE(moved.frames.size() == 1);
  CHECK((moved.frames[0].id == 0x7FF && moved.frames[0].data[1] == 0xBB && moved.names[0] == "can1"));
  CHECK(located(read(";$FILEVERSION=3.0\n")) == std::vector<std::string>{
                                                "1:15 TRC file version '3.0' is not one of 1.0 1.1 1.2 1.3 2.0 2.1"});
}

TEST_CASE("TRC writer: version 2.1 lines, an exact start time, buses by first appearance") {
  std::ostringstream out;
  TrcWriter w(out);
  CanFrame f;
  f.id = 0x938;
  f.extended = true;
  f.dlc = 2;
  f.data = {0xAB, 0xCD};
  f.timestamp_ns = 1'700'000'000'123'456'789ULL;
  w.write(f, "can0");
  CanFrame r;
  r.id = 0x123;
  r.remote = true;
  r.dlc = 4;
  r.timestamp_ns = f.timestamp_ns;
  w.write(r, "vcan7");
  CanFrame e;
  e.error = true;
  e.id = 0x004;
  e.dlc = 8;
  e.timestamp_ns = *f.timestamp_ns + 1'000'000'000ULL;
  w.write(e, "can0");
  w.close();
  std::vector<std::string> lines;
  std::istringstream in(out.str());
  for (std::string line; std::getline(in, line);) {
    REQUIRE(line.ends_with("\r"));  // CRLF, as PEAK's tools write
    line.pop_back();
    if (!line.starts_with(";") || line.starts_with(";$")) lines.push_back(line);
  }
  // the last multiple of 0.864 s (1e-5 days) before 1700000000.123456789 s is 1699999999.488 s, 45244.92592 days
  // after 1899-12-30; the first frame is 635.456789 ms later
  REQUIRE(lines.size() == 6);
  CHECK(lines[0] == ";$FILEVERSION=2.1");
  CHECK(lines[1] == ";$STARTTIME=45244.9259200000");
  CHECK(lines[2] == ";$COLUMNS=N,O,T,B,I,d,R,L,D");
  CHECK(lines[3] == "      1       635.456 DT  1 00000938 Rx -  2    AB CD");
  CHECK(lines[4] == "      2       635.456 RR  2     0123 Rx -  4");
  CHECK(lines[5] == "      3      1635.456 ER  1        - Rx -  0");
  const TrcRead back = read(out.str());
  REQUIRE(back.frames.size() == 3);
  CHECK(*back.frames[0].timestamp_ns == 1'700'000'000'123'456'000ULL);  // microseconds kept
  CHECK(back.names == std::vector<std::string>{"can0", "can1", "can0"});
}
