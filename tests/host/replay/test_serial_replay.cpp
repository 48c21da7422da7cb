// Serial replay (saulproto/host/replay/serial_replay.hpp) on a fake clock and a fake port: the exact bytes of every write
// for hand-built captures with motion and other frames, noise, frames split over chunks and an unfinished frame at
// the end; dropped counts; deadlines from the timestamps (speed 2, loops); single step; the motion rule per message;
// the frame splitter against the streaming decoders; the port settings that follow the captured link.
//
// Frames are the golden bytes of docs/protocol.md (tests/unit/test_interboard.cpp, test_crsf.cpp, test_pride.cpp).
#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/core/crsf.hpp"
#include "saulproto/core/rc_input.hpp"
#include "saulproto/host/replay/serial_replay.hpp"

using namespace saul;
using namespace saul::host;
using Bytes = std::vector<std::uint8_t>;

namespace {

constexpr std::uint64_t kMs = 1'000'000ULL;
constexpr std::uint64_t kStart = 7'000 * kMs;  // the fake clock's time when a replay starts

Bytes hex(std::string_view text) {
  Bytes out;
  for (std::size_t i = 0; i + 1 < text.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoul(std::string(text.substr(i, 2)), nullptr, 16)));
  return out;
}

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// Inter-board golden frames (docs/protocol.md §2 and §7).
const Bytes kState = hex("AA05102EFB2C010151");    // state: BALANCE -> IO, kept
const Bytes kRcCmd = hex("AA0501F40106FF010F");    // rc_cmd throttle 500, armed: motion
const Bytes kRcKill = hex("AA05010000000003D5");   // rc_cmd armed + kill (estop): kept
const Bytes kFault = hex("AA0103056A");            // fault rc_loss + estop: kept
const Bytes kSensor = hex("AA0502D204C8FF0114");   // sensor: kept
const Bytes kBuzzer = hex("AA031203F40127");       // buzzer: kept
const Bytes kBadCrc = hex("AA0103056B");           // fault with a wrong CRC: no frame

/// Time moves only when the replay waits (to the deadline, or later by `oversleep`).
struct FakeClock final : ReplayClock {
  std::uint64_t now = kStart;
  std::uint64_t oversleep = 0;
  std::vector<std::uint64_t> deadlines;
  std::uint64_t now_ns() override { return now; }
  bool sleep_until(std::uint64_t deadline) override {
    deadlines.push_back(deadline - kStart);
    if (deadline > now) now = deadline + oversleep;
    return true;
  }
};

/// A serial log held in memory, opened afresh for every pass.
struct Log {
  explicit Log(std::string t) : text(std::move(t)) {}
  std::string text;
  std::vector<std::unique_ptr<std::istringstream>> streams;
  std::function<std::unique_ptr<SerialCaptureReader>()> opener() {
    return [this] {
      streams.push_back(std::make_unique<std::istringstream>(text));
      return std::unique_ptr<SerialCaptureReader>(std::make_unique<SerialLogReader>(*streams.back()));
    };
  }
};

/// The fake port: every write, with the fake clock's time (relative to the start).
struct Port {
  explicit Port(FakeClock& c) : clock(c) {}
  FakeClock& clock;
  std::vector<Bytes> writes;
  std::vector<std::uint64_t> at;
  SerialReplayHooks hooks() {
    SerialReplayHooks h;
    h.write = [this](std::span<const std::uint8_t> b) {
      writes.emplace_back(b.begin(), b.end());
      at.push_back(clock.now - kStart);
    };
    return h;
  }
};

constexpr const char* kIb = "serial:/dev/ttyUSB0@460800:8N1 interboard ";

std::string line(const char* when, const char* link_protocol, std::string_view bytes) {
  return std::string("(") + when + ") " + link_protocol + std::string(bytes) + "\n";
}

// The inter-board capture of most tests: 9 chunks. Chunk 2 ends inside the motion rc_cmd, whose rest opens chunk 3;
// chunk 7 is one whole motion rc_cmd (nothing left to write); chunk 9 is an unfinished frame at the end of the file.
const std::string kInterboardLog =
    "# hand-built\n" + line("100.000000", kIb, "AA05102EFB2C010151")  // state
    + line("100.010000", kIb, "0055AA0501F401")                      // noise 00 55, rc_cmd (first 5 bytes)
    + line("100.020000", kIb, "06FF010FAA0103056A")                  // rc_cmd (last 4 bytes), fault
    + line("100.030000", kIb, "AA05010000000003D5")                  // rc_cmd with kill: an estop
    + line("100.040000", kIb, "AA0103056B")                          // bad CRC
    + line("100.050000", kIb, "AAAA0502D204C8FF0114")                // a noise AA, then sensor
    + line("100.060000", kIb, "AA0501F40106FF010F")                  // rc_cmd: the whole chunk is motion
    + line("100.070000", kIb, "AA031203F40127")                      // buzzer
    + line("100.080000", kIb, "AA0501F4");                           // an rc_cmd cut short by the end

const std::vector<Bytes> kInterboardWrites{
    kState, hex("0055"), kFault, kRcKill, kBadCrc, cat({hex("AA"), kSensor}), kBuzzer, hex("AA0501F4")};
const std::vector<std::uint64_t> kInterboardDeadlines{0,       10 * kMs, 20 * kMs, 30 * kMs,
                                                      40 * kMs, 50 * kMs, 70 * kMs, 80 * kMs};

std::vector<SerialPiece> split_all(SerialProtocol protocol, const Bytes& bytes, std::size_t step) {
  SerialFrameSplitter s(protocol);
  std::vector<SerialPiece> pieces;
  auto on = [&](const SerialPiece& p) { pieces.push_back(p); };
  for (std::size_t i = 0; i < bytes.size(); i += step)
    s.push(std::span<const std::uint8_t>(bytes).subspan(i, std::min(step, bytes.size() - i)), on);
  s.finish(on);
  CHECK(s.pending() == 0);
  return pieces;
}

/// (size, name or "-", motion) of each piece, runs of bytes in no frame merged (the splitter hands them out at the
/// end of every push, so how they are cut depends on the pushes): easy to compare.
struct P {
  std::size_t size;
  std::string name;
  bool motion;
  bool operator==(const P&) const = default;
};
std::ostream& operator<<(std::ostream& os, const P& p) {
  return os << "{" << p.size << " " << p.name << (p.motion ? " motion" : "") << "}";
}
std::vector<P> simple(const std::vector<SerialPiece>& pieces) {
  std::vector<P> out;
  for (const auto& p : pieces) {
    if (!p.message && !out.empty() && out.back().name == "-")
      out.back().size += p.size;
    else
      out.push_back({p.size, p.message ? name_of(*p.message) : "-", p.motion});
  }
  return out;
}

std::uint64_t decoder_frames(SerialProtocol protocol, const Bytes& bytes) {
  SerialStreamDecoder d(protocol);
  const SerialStreamDecoder::Callback ignore = [](const SerialMessage&) {};
  d.push(bytes, ignore);
  d.finish(ignore);
  return d.counters().frames;
}

Bytes crsf_rc(std::uint16_t ch2_us, std::uint16_t ch6_us) {
  crsf::RcChannels rc;
  for (auto& t : rc.ticks) t = crsf::kTicksMid;
  rc.ticks[1] = crsf::us_to_ticks(ch2_us);
  rc.ticks[5] = crsf::us_to_ticks(ch6_us);
  std::array<std::uint8_t, crsf::kMaxFrameSize> buf{};
  const auto n = crsf::encode(rc, buf);
  REQUIRE(n.ok());
  return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n.value()));
}

}  // namespace

namespace {
// A decoded CRSF message as a receiver addresses it (0xC8).
SerialMessage crsf_message(const crsf::Message& m) { return SerialMessage(CrsfMessage{crsf::kSyncByte, m}); }
}  // namespace

TEST_CASE("serial motion rule: which messages can move motors") {
  CHECK(can_move_motors(SerialMessage(interboard::Message(interboard::RcCmd{500, -250, 0x01}))));
  CHECK(can_move_motors(SerialMessage(interboard::Message(interboard::RcCmd{0, 0, 0x00}))));  // arming, sticks still
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::RcCmd{0, 0, 0x03}))));  // kill: estop
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::RcCmd{300, 0, 0x02}))));
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::Fault{0x04}))));
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::Sensor{}))));
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::State{}))));
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::LedCmd{}))));
  CHECK_FALSE(can_move_motors(SerialMessage(interboard::Message(interboard::Buzzer{}))));

  crsf::RcChannels rc;
  for (auto& t : rc.ticks) t = crsf::kTicksMid;
  CHECK(can_move_motors(crsf_message(crsf::Message(rc))));
  rc.ticks[rc::kEstopChannel] = crsf::us_to_ticks(1501);  // CH6 past centre: estop
  CHECK_FALSE(can_move_motors(crsf_message(crsf::Message(rc))));
  rc.ticks[rc::kEstopChannel] = crsf::us_to_ticks(1500);  // exactly 1500 is not estop
  CHECK(can_move_motors(crsf_message(crsf::Message(rc))));
  CHECK_FALSE(can_move_motors(crsf_message(crsf::Message(crsf::LinkStatistics{}))));
  CHECK_FALSE(can_move_motors(crsf_message(crsf::Message(crsf::BatterySensor{}))));
  CrsfUndecoded short_rc;
  short_rc.frame.type = static_cast<std::uint8_t>(crsf::Type::rc_channels_packed);
  short_rc.reason = Reason::bad_length;
  CHECK(can_move_motors(SerialMessage(short_rc)));  // an RC frame that does not decode still counts
  CrsfUndecoded other;
  other.frame.type = 0x3A;
  CHECK_FALSE(can_move_motors(SerialMessage(other)));

  CHECK(can_move_motors(SerialMessage(pride::Message(pride::VcuCommand{7, 50, 0}))));
  CHECK(can_move_motors(SerialMessage(pride::Message(pride::VcuCommand{7, 0, 0}))));  // neutral: still a drive frame
  CHECK_FALSE(can_move_motors(SerialMessage(pride::Message(pride::ControllerStatus{0x02, 100, 0}))));
}

TEST_CASE("splitter: inter-board frames, noise, a false start and an unfinished frame, in any chunking") {
  const Bytes stream = cat({kState, hex("0055"), kRcCmd, kFault, kRcKill, kBadCrc, hex("AA"), kSensor, kBuzzer,
                            hex("AA0501F4")});
  const std::vector<P> expect{{9, "state", false}, {2, "-", false},  {9, "rc_cmd", true},  {5, "fault", false},
                              {9, "rc_cmd", false}, {6, "-", false}, {9, "sensor", false}, {7, "buzzer", false},
                              {4, "-", false}};
  for (std::size_t step : {std::size_t{1}, std::size_t{2}, std::size_t{5}, std::size_t{7}, stream.size()}) {
    INFO("pushed " << step << " bytes at a time");
    const auto pieces = split_all(SerialProtocol::interboard, stream, step);
    CHECK(simple(pieces) == expect);
  }
  // The same frames as the streaming decoder finds in the whole stream.
  std::uint64_t frames = 0;
  for (const auto& p : split_all(SerialProtocol::interboard, stream, 3)) frames += p.message ? 1 : 0;
  CHECK(frames == decoder_frames(SerialProtocol::interboard, stream));

  // A real frame that begins inside a false candidate (the decoder's rescan, docs/protocol.md §2 step 5): a noise
  // AA 05 01 opens a 9-byte rc_cmd candidate that swallows a real fault frame.
  const Bytes swallowed = cat({hex("AA0501"), kFault, hex("33"), kState});
  CHECK(simple(split_all(SerialProtocol::interboard, swallowed, 1)) ==
        std::vector<P>{{3, "-", false}, {5, "fault", false}, {1, "-", false}, {9, "state", false}});
}

TEST_CASE("splitter: CRSF frames behind a noise sync byte with a long LEN, mid-stream and at the end") {
  const Bytes t1 = hex("C81816E0031FF8C0073EF0810F7CE0031FF8C0073EF0810F7CAD");  // RC, all centred: motion
  const Bytes t3 = hex("C80C143C3E640900040337620895");                      // link statistics
  const Bytes t7 = hex("C8040B00C8ED");                                            // heartbeat
  const Bytes estop = crsf_rc(2012, 2012);  // full throttle, but CH6 estop: goes through
  const Bytes drive = crsf_rc(1700, 988);   // throttle, no estop: motion
  REQUIRE(estop.size() == 26);
  // C8 3E opens a 64-byte candidate; its CRC fails only when all 64 bytes are in, and the frames inside it are
  // found by the rescan.
  const Bytes mid = cat({hex("C83E"), t1, t3, t7, estop, drive, t7});
  const std::vector<P> expect_mid{{2, "-", false},           {26, "rc_channels", true},  {14, "link_statistics", false},
                                  {6, "heartbeat", false},   {26, "rc_channels", false}, {26, "rc_channels", true},
                                  {6, "heartbeat", false}};
  for (std::size_t step : {std::size_t{1}, std::size_t{13}, mid.size()}) {
    INFO("pushed " << step << " bytes at a time");
    CHECK(simple(split_all(SerialProtocol::crsf, mid, step)) == expect_mid);
  }
  CHECK(decoder_frames(SerialProtocol::crsf, mid) == 6);
  // At the end of the stream the candidate is still open: finish() gives it up and the rest is found all the same.
  const Bytes end = cat({hex("C83E"), t1, t7});
  CHECK(simple(split_all(SerialProtocol::crsf, end, 1)) ==
        std::vector<P>{{2, "-", false}, {26, "rc_channels", true}, {6, "heartbeat", false}});
  CHECK(decoder_frames(SerialProtocol::crsf, end) == 2);
}

TEST_CASE("splitter: Pride frames; an out-of-range command is no frame; raw is all noise") {
  const Bytes stream = cat({hex("FE5407320074"), hex("4A010264004E"), hex("12"), hex("FE540F00009E"),
                            hex("FE54070000A6"), hex("4A010264004E")});
  CHECK(simple(split_all(SerialProtocol::pride, stream, 1)) ==
        std::vector<P>{{6, "vcu_command", true},
                       {6, "controller_status", false},
                       {7, "-", false},  // 12 and the speed level 0x0F command (checksum fine, out of range)
                       {6, "vcu_command", true},
                       {6, "controller_status", false}});
  CHECK(decoder_frames(SerialProtocol::pride, stream) == 4);
  // raw: every byte at once, in no frame (one piece per push)
  const auto raw = split_all(SerialProtocol::raw, kRcCmd, 4);
  REQUIRE(raw.size() == 3);
  CHECK((raw[0].size == 4 && raw[1].size == 4 && raw[2].size == 1 && !raw[0].message && !raw[2].motion));
}

TEST_CASE("serial replay: exact bytes of every write, motion left out, deadlines from the timestamps") {
  Log log{kInterboardLog};
  FakeClock clock;
  Port port{clock};
  const SerialReplayReport r = replay_serial(log.opener(), SerialReplayOptions{}, clock, port.hooks());
  CHECK(port.writes == kInterboardWrites);
  CHECK(clock.deadlines == kInterboardDeadlines);
  CHECK(port.at == kInterboardDeadlines);
  CHECK(r.chunks == 9);
  CHECK(r.bytes == 9 + 7 + 9 + 9 + 5 + 10 + 9 + 7 + 4);
  CHECK(r.writes == 8);
  CHECK(r.bytes_sent == r.bytes - 18);
  CHECK(r.frames == 7);
  CHECK(r.motion_dropped == 2);
  CHECK(r.motion_bytes == 18);
  CHECK(r.motion_by_type == std::map<std::string, std::uint64_t>{{"rc_cmd", 2}});
  CHECK(r.motion_sent == 0);
  CHECK(r.protocol == SerialProtocol::interboard);
  CHECK(r.link == "serial:/dev/ttyUSB0@460800:8N1");
  CHECK(r.lateness.count() == 8);
  CHECK(r.lateness.max_ns() == 0);
  CHECK(r.elapsed_ns == 80 * kMs);
  CHECK_FALSE(r.stopped);
}

TEST_CASE("serial replay: --allow-motion writes every chunk exactly as captured") {
  Log log{kInterboardLog};
  FakeClock clock;
  Port port{clock};
  SerialReplayOptions o;
  o.allow_motion = true;
  const SerialReplayReport r = replay_serial(log.opener(), o, clock, port.hooks());
  const std::vector<Bytes> chunks{kState,  hex("0055AA0501F401"), hex("06FF010FAA0103056A"), kRcKill, kBadCrc,
                                  hex("AAAA0502D204C8FF0114"), kRcCmd, kBuzzer, hex("AA0501F4")};
  CHECK(port.writes == chunks);
  CHECK(clock.deadlines ==
        std::vector<std::uint64_t>{0, 10 * kMs, 20 * kMs, 30 * kMs, 40 * kMs, 50 * kMs, 60 * kMs, 70 * kMs, 80 * kMs});
  CHECK(r.motion_dropped == 0);
  CHECK(r.motion_sent == 2);
  CHECK(r.bytes_sent == r.bytes);
}

TEST_CASE("serial replay: speed 2 halves the deadlines; a late write never moves the schedule") {
  Log log{kInterboardLog};
  FakeClock clock;
  clock.oversleep = 3 * kMs;  // every wake-up is 3 ms late
  Port port{clock};
  SerialReplayOptions o;
  o.speed = 2;
  const SerialReplayReport r = replay_serial(log.opener(), o, clock, port.hooks());
  std::vector<std::uint64_t> half;
  for (auto d : kInterboardDeadlines) half.push_back(d / 2);
  CHECK(clock.deadlines == half);
  CHECK(port.writes == kInterboardWrites);
  // Each write leaves 3 ms after its deadline (deadline 0 is already due: no wait, on time).
  CHECK(r.lateness.count() == 8);
  CHECK(r.lateness.max_ns() == 3 * kMs);
  CHECK(r.lateness.over_1ms() == 7);
}

TEST_CASE("serial replay: --loop 2 repeats the bytes; the next pass starts one mean interval after the last write") {
  Log log{kInterboardLog};
  FakeClock clock;
  Port port{clock};
  SerialReplayOptions o;
  o.loops = 2;
  const SerialReplayReport r = replay_serial(log.opener(), o, clock, port.hooks());
  std::vector<Bytes> twice = kInterboardWrites;
  twice.insert(twice.end(), kInterboardWrites.begin(), kInterboardWrites.end());
  CHECK(port.writes == twice);
  // 8 writes over 80 ms: mean interval 80/7 ms; the second pass's deadlines follow from there.
  const std::uint64_t second = 80 * kMs + 80 * kMs / 7;
  std::vector<std::uint64_t> expect = kInterboardDeadlines;
  for (auto d : kInterboardDeadlines) expect.push_back(second + d);
  CHECK(clock.deadlines == expect);
  CHECK(r.passes == 2);
  CHECK(r.motion_dropped == 4);
  CHECK(r.chunks == 18);
  CHECK(r.writes == 16);
}

TEST_CASE("serial replay: max gap, speed max, single step") {
  SECTION("--max-gap shortens a long silence") {
    Log log{line("10.000000", kIb, "AA05102EFB2C010151") + line("70.000000", kIb, "AA031203F40127")};
    FakeClock clock;
    Port port{clock};
    SerialReplayOptions o;
    o.max_gap_ns = 1000 * kMs;
    replay_serial(log.opener(), o, clock, port.hooks());
    CHECK(clock.deadlines == std::vector<std::uint64_t>{0, 1000 * kMs});
  }
  SECTION("speed 0 (max) does not wait and records no lateness") {
    Log log{kInterboardLog};
    FakeClock clock;
    Port port{clock};
    SerialReplayOptions o;
    o.speed = 0;
    const auto r = replay_serial(log.opener(), o, clock, port.hooks());
    CHECK(clock.deadlines.empty());
    CHECK(port.writes == kInterboardWrites);
    CHECK(r.lateness.count() == 0);
  }
  SECTION("step: one chunk per answer with the bytes that will go out, no timing, false stops") {
    Log log{kInterboardLog};
    FakeClock clock;
    Port port{clock};
    auto hooks = port.hooks();
    std::vector<Bytes> asked;
    std::vector<std::size_t> chunk_sizes;
    hooks.step = [&](const SerialChunk& chunk, std::span<const std::uint8_t> bytes) {
      asked.emplace_back(bytes.begin(), bytes.end());
      chunk_sizes.push_back(chunk.bytes.size());
      return asked.size() < 3;
    };
    const auto r = replay_serial(log.opener(), SerialReplayOptions{}, clock, hooks);
    CHECK(asked == std::vector<Bytes>{kState, hex("0055"), kFault});
    CHECK(chunk_sizes == std::vector<std::size_t>{9, 7, 9});
    CHECK(port.writes == std::vector<Bytes>{kState, hex("0055")});
    CHECK(clock.deadlines.empty());
    CHECK(r.stopped);
  }
  SECTION("stop() ends the replay before the next write") {
    Log log{kInterboardLog};
    FakeClock clock;
    Port port{clock};
    auto hooks = port.hooks();
    hooks.stop = [&] { return port.writes.size() == 2; };
    const auto r = replay_serial(log.opener(), SerialReplayOptions{}, clock, hooks);
    CHECK(port.writes.size() == 2);
    CHECK(r.stopped);
  }
}

TEST_CASE("serial replay: one link of several, corrupt lines, a protocol given for a raw link") {
  const std::string text = line("1.000000", "uart-1:RX raw ", "FE5407320074") +
                           line("1.001000", "uart-1:TX raw ", "AA0501F40106FF010F") +
                           "(1.002000 uart-1:RX raw 00\n" +  // corrupt: no ')'
                           line("1.005000", "uart-1:RX raw ", "4A010264004E");
  Log log{text};
  FakeClock clock;
  Port port{clock};
  SerialReplayOptions o;
  o.link = "uart-1:RX";
  o.protocol = SerialProtocol::pride;
  int corrupt_seen = 0;
  auto hooks = port.hooks();
  hooks.on_corrupt = [&](const CaptureError&) { ++corrupt_seen; };
  const auto r = replay_serial(log.opener(), o, clock, hooks);
  CHECK(port.writes == std::vector<Bytes>{hex("4A010264004E")});
  CHECK(clock.deadlines == std::vector<std::uint64_t>{0});
  CHECK(r.other_links == 1);
  CHECK(r.corrupt == 1);
  CHECK(corrupt_seen == 1);
  CHECK(r.motion_by_type == std::map<std::string, std::uint64_t>{{"vcu_command", 1}});
}

TEST_CASE("serial replay preview: links, protocols named or guessed, what would be left out") {
  // uart-1 names no protocol: its bytes (4 Pride periods) make the guess.
  std::string text = line("0.000100", kIb, "AA0501F40106FF010F") + line("0.001100", kIb, "AA05102EFB2C010151");
  for (int i = 0; i < 4; ++i) {
    text += line("0.002000", "uart-1 raw ", "FE5407320074");
    text += line("0.004000", "uart-1 raw ", "4A010264004E");
  }
  std::istringstream in(text);
  SerialLogReader reader(in);
  const auto p = preview_serial_replay(reader);
  REQUIRE(p.links.size() == 2);
  const SerialLinkPreview* ib = p.find("serial:/dev/ttyUSB0@460800:8N1");
  const SerialLinkPreview* u = p.find("uart-1");
  REQUIRE(ib != nullptr);
  REQUIRE(u != nullptr);
  CHECK(ib->protocol == SerialProtocol::interboard);
  CHECK_FALSE(ib->guessed);
  CHECK(ib->chunks == 2);
  CHECK(ib->frames == 2);
  CHECK(ib->motion == 1);
  CHECK(ib->writes == 1);
  CHECK(u->protocol == SerialProtocol::pride);
  CHECK(u->guessed);
  CHECK(u->frames == 8);
  CHECK(u->motion == 4);
  CHECK(u->motion_bytes == 24);
  CHECK(u->writes == 4);
  CHECK(format_motion_by_type(u->motion_by_type) == "vcu_command 4");

  std::istringstream in2(text);
  SerialLogReader reader2(in2);
  const auto given = preview_serial_replay(reader2, SerialProtocol::raw);  // --protocol raw: nothing recognised
  CHECK(given.find("uart-1")->protocol == SerialProtocol::raw);
  CHECK(given.find("uart-1")->motion == 0);
}

TEST_CASE("serial replay port: the rate follows the captured link, else its protocol") {
  auto s = replay_serial_settings("serial:/dev/ttyUSB0@460800:8N1", SerialProtocol::interboard);
  REQUIRE(s);
  CHECK(to_string(*s) == "8N1");
  CHECK(s->baud == 460800);
  s = replay_serial_settings("serial:/dev/ttyUSB0@115200:8N1", SerialProtocol::interboard);  // recorded slower
  CHECK(s->baud == 115200);
  s = replay_serial_settings("uart-1:RX", SerialProtocol::pride);
  CHECK(s->baud == 38400);
  CHECK(to_string(*s) == "8E1");
  s = replay_serial_settings("serial:/dev/ttyUSB1@38400", SerialProtocol::pride);  // no format in the name
  CHECK(to_string(*s) == "8E1");
  s = replay_serial_settings("uart-1", SerialProtocol::crsf);
  CHECK(s->baud == 420000);
  CHECK(to_string(*s) == "8N1");
  CHECK_FALSE(replay_serial_settings("uart-1", SerialProtocol::raw));
  s = replay_serial_settings("serial:/dev/ttyUSB2@9600:8N1", SerialProtocol::raw);
  CHECK(s->baud == 9600);
  // The name is read by the one link parser: a rate with its unit as every link takes it, and a name it refuses
  // (a frame format that is none) gives the protocol's own settings.
  s = replay_serial_settings("serial:/dev/ttyUSB1@460k", SerialProtocol::interboard);
  CHECK(s->baud == 460000);
  CHECK(to_string(*s) == "8N1");
  s = replay_serial_settings("serial:/dev/ttyUSB1@9600:9Q7", SerialProtocol::pride);
  CHECK(s->baud == 38400);
  CHECK(to_string(*s) == "8E1");

  const auto pride_port = replay_serial_settings("uart-1", SerialProtocol::pride);
  CHECK(parse_serial_replay_link("serial:/dev/pts/3", pride_port).text() == "serial:/dev/pts/3@38400:8E1");
  CHECK(parse_serial_replay_link("serial:/dev/pts/3@9600", pride_port).text() == "serial:/dev/pts/3@9600:8E1");
  CHECK(parse_serial_replay_link("serial:/dev/pts/3@9600:8N1", pride_port).text() == "serial:/dev/pts/3@9600:8N1");
  CHECK(parse_serial_replay_link("serial:/dev/pts/3@9600", std::nullopt).text() == "serial:/dev/pts/3@9600:8N1");
  CHECK_THROWS_AS(parse_serial_replay_link("serial:/dev/pts/3", std::nullopt), std::invalid_argument);
  CHECK_THROWS_AS(parse_serial_replay_link("can0", pride_port), std::invalid_argument);
  CHECK_THROWS_AS(parse_serial_replay_link("serial:/dev/pts/3@fast", pride_port), std::invalid_argument);
}
