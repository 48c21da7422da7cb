// The two CSV logs: python-can's (base64 data; rows as python-can 4.1's CSVWriter formats them, the base64 taken
// from Python's base64 module) and SavvyCAN's native "GVRET" CSV (rows as SavvyCAN's saveNativeCSVFile lays them
// out, and the older layout without the Dir column).
#include <catch2/catch.hpp>

#include <array>
#include <sstream>
#include <string>
#include <vector>

#include "formats_test.hpp"
#include "saulproto/host/capture/csv_log.hpp"
#include "saulproto/host/capture/gvret_csv.hpp"

using namespace saul;
using namespace saul::host;

namespace {

using capture_test::located;
using capture_test::Read;
using capture_test::read_with;

}  // namespace

TEST_CASE("base64 as Python's base64 module writes it") {
  const std::array<std::uint8_t, 8> status = {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA};
  CHECK(base64_encode(status) == "///7UAAjAPo=");  // base64.b64encode(bytes.fromhex("FFFFFB50002300FA"))
  CHECK(base64_encode(std::array<std::uint8_t, 4>{0x00, 0x00, 0x05, 0xDC}) == "AAAF3A==");
  CHECK(base64_encode(std::span<const std::uint8_t>()).empty());
  std::array<std::uint8_t, 8> out{};
  CHECK(base64_decode("///7UAAjAPo=", out) == 8);
  CHECK(out == status);
  CHECK(base64_decode("AAAF3A", out) == 4);  // padding optional
  CHECK(base64_decode("AAAF3A==AAAA", out) == -1);
  CHECK(base64_decode("AAAAAAAAAAAAAAAA", out) == -1);  // 12 bytes do not fit a classic frame
  CHECK(base64_decode("AA*A", out) == -1);
}

TEST_CASE("python-can CSV: rows as CSVWriter writes them, error frames with their class") {
  const Read r = read_with<CsvLogReader>(
      "timestamp,arbitration_id,extended,remote,error,dlc,data\n"
      "1700000000.00125,0x938,1,0,0,8,///7UAAjAPo=\n"
      "1700000000.0,0x344,1,0,0,4,AAAF3A==\n"
      "1700000001.5,0x123,0,1,0,4,\n"
      "1700000002.25,0x4,0,0,1,8,AAQAAAAAAAA=\n"
      "1e-05,0x7ff,0,0,0,0,\n"
      "1700000003.0,0x800,0,0,0,0,\n"
      "1700000003.0,0x300,0,0,0,4,AAAF\n");
  REQUIRE(r.frames.size() == 5);
  CHECK(*r.frames[0].timestamp_ns == 1'700'000'000'001'250'000ULL);
  CHECK((r.frames[0].id == 0x938 && r.frames[0].extended && r.frames[0].dlc == 8 && r.frames[0].data[7] == 0xFA));
  CHECK((r.frames[2].remote && r.frames[2].dlc == 4));
  CHECK((r.frames[3].error && r.frames[3].id == 0x004 && r.frames[3].data[1] == 0x04));  // SocketCAN class kept
  CHECK(*r.frames[4].timestamp_ns == 10'000ULL);  // Python writes 0.00001 as 1e-05
  CHECK(r.names == std::vector<std::string>(5, "can0"));
  CHECK(located(r) == std::vector<std::string>{"7:14 11-bit id above 7FF (extended is 0)", "8:28 dlc 4 but 3 data bytes"});
  CHECK(located(read_with<CsvLogReader>("time,id\n1,2\n")).front() ==
        "1:1 not python-can's CSV header (timestamp,arbitration_id,extended,remote,error,dlc,data)");
}

TEST_CASE("python-can CSV writer: python-can's header and row layout") {
  std::ostringstream out;
  CsvLogWriter w(out);
  CanFrame f;
  f.id = 0x938;
  f.extended = true;
  f.dlc = 8;
  f.data = {0xFF, 0xFF, 0xFB, 0x50, 0x00, 0x23, 0x00, 0xFA};
  f.timestamp_ns = 1'700'000'000'001'250'999ULL;
  w.write(f, "can3");
  w.close();
  CHECK(out.str() ==
        "timestamp,arbitration_id,extended,remote,error,dlc,data\n"
        "1700000000.001250,0x938,1,0,0,8,///7UAAjAPo=\n");
}

TEST_CASE("SavvyCAN CSV: both layouts, 29-bit by flag or by size, bus numbers") {
  const Read v2 = read_with<GvretCsvReader>(
      "Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n"
      "39747828,000005EB,false,Rx,0,8,E8,45,85,4B,4A,28,36,69,\n"
      "39747900,00000938,true,Tx,1,2,FF,FF,00,00,00,00,00,00,\n"
      "39748000,00001B38,false,Rx,0,0,00,00,00,00,00,00,00,00,\n"
      "39748100,00000300,false,Rx,0,9,00,00,00,00,00,00,00,00,00,\n"
      "39748200,00000300,false,Rx,0,4,E8,03\n");
  REQUIRE(v2.frames.size() == 3);
  CHECK(*v2.frames[0].timestamp_ns == 39'747'828'000ULL);
  CHECK((v2.frames[0].id == 0x5EB && !v2.frames[0].extended && v2.frames[0].data[7] == 0x69));
  CHECK((v2.frames[1].id == 0x938 && v2.frames[1].extended && v2.frames[1].dlc == 2));
  CHECK((v2.frames[2].id == 0x1B38 && v2.frames[2].extended));  // above 7FF: 29-bit, as SavvyCAN reads it
  CHECK(v2.names == std::vector<std::string>{"can0", "can1", "can0"});
  CHECK(located(v2) == std::vector<std::string>{
                         "5:30 LEN above 8 (CAN FD): the robot's bus is classic CAN, FD is not supported",
                         "6:37 LEN is 4 but 2 data bytes follow"});
  const Read v1 = read_with<GvretCsvReader>(
      "Time Stamp,ID,Extended,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n1500,00000300,false,2,4,E8,03,0C,FE,00,00,00,00,\n");
  REQUIRE(v1.frames.size() == 1);
  CHECK((v1.frames[0].dlc == 4 && v1.frames[0].data[3] == 0xFE && v1.names[0] == "can2"));
}

TEST_CASE("SavvyCAN CSV writer: SavvyCAN's layout, no remote or error frames") {
  std::ostringstream out;
  GvretCsvWriter w(out);
  CanFrame f;
  f.id = 0x300;
  f.dlc = 2;
  f.data = {0xE8, 0x03};
  f.timestamp_ns = 1'700'000'000'001'250'999ULL;
  w.write(f, "can0");
  CanFrame r = f;
  r.remote = true;
  w.write(r, "can0");
  f.extended = true;
  w.write(f, "vcan9");
  w.close();
  CHECK(out.str() ==
        "Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n"
        "1700000000001250,00000300,false,Rx,0,2,E8,03,00,00,00,00,00,00,\n"
        "1700000000001250,00000300,true,Rx,1,2,E8,03,00,00,00,00,00,00,\n");
}
