// Fake hardware for the firmware logic, and rigs that drive one board (or both, wired together) in simulated time.
// Nothing here sleeps or reads a clock: time is a number the rig advances.
//
// Frames the boards SEND are checked against bytes written out here by hand (hand-rolled CRCs below), never against
// the encoders the boards themselves use. Frames the boards RECEIVE may be built with libsaulproto's encoders,
// which have their own golden tests in tests/unit.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "saulfw/balance.hpp"
#include "saulfw/io.hpp"
#include "saulproto/core/crsf.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/saul_can.hpp"

namespace fwtest {

using namespace saul;
using namespace saul::fw;
using Bytes = std::vector<std::uint8_t>;

// ---- hand-rolled checksums and frames ---------------------------------------------------------------------------

/// CRC-8/MAXIM, bit by bit (reflected poly 0x8C, init 0).
inline std::uint8_t crc8_maxim(const Bytes& data) {
  std::uint8_t crc = 0;
  for (std::uint8_t b : data) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = static_cast<std::uint8_t>((crc & 1U) ? (crc >> 1) ^ 0x8CU : crc >> 1);
  }
  return crc;
}

/// CRC-8/DVB-S2, bit by bit (poly 0xD5, init 0).
inline std::uint8_t crc8_dvb_s2(const Bytes& data) {
  std::uint8_t crc = 0;
  for (std::uint8_t b : data) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = static_cast<std::uint8_t>((crc & 0x80U) ? (crc << 1) ^ 0xD5U : crc << 1);
  }
  return crc;
}

/// An inter-board frame: AA LEN TYPE PAYLOAD CRC.
inline Bytes ib_frame(std::uint8_t type, const Bytes& payload) {
  Bytes covered;  // (element by element: GCC 12 warns falsely about vector::insert here)
  covered.push_back(type);
  for (std::uint8_t b : payload) covered.push_back(b);
  Bytes f;
  f.push_back(0xAA);
  f.push_back(static_cast<std::uint8_t>(payload.size()));
  for (std::uint8_t b : covered) f.push_back(b);
  f.push_back(crc8_maxim(covered));
  return f;
}

inline Bytes le16(std::int32_t v) {
  const auto u = static_cast<std::uint16_t>(v);
  return {static_cast<std::uint8_t>(u & 0xFF), static_cast<std::uint8_t>(u >> 8)};
}

inline Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts)
    for (std::uint8_t b : p) out.push_back(b);
  return out;
}

/// A CRSF frame as a receiver sends it: C8 LEN TYPE PAYLOAD CRC.
inline Bytes crsf_frame(std::uint8_t type, const Bytes& payload, std::uint8_t address = 0xC8) {
  Bytes covered;
  covered.push_back(type);
  for (std::uint8_t b : payload) covered.push_back(b);
  Bytes f;
  f.push_back(address);
  f.push_back(static_cast<std::uint8_t>(payload.size() + 2));
  for (std::uint8_t b : covered) f.push_back(b);
  f.push_back(crc8_dvb_s2(covered));
  return f;
}

/// RC_CHANNELS_PACKED from 16 channel values in microseconds, packed by hand (11 bits each, LSB first).
inline Bytes crsf_rc_frame(const std::array<std::uint16_t, 16>& us) {
  Bytes payload(22, 0);
  for (std::size_t ch = 0; ch < 16; ++ch) {
    const std::uint16_t ticks = crsf::us_to_ticks(us[ch]);
    for (int bit = 0; bit < 11; ++bit) {
      if (((ticks >> bit) & 1U) == 0) continue;
      const std::size_t k = ch * 11 + static_cast<std::size_t>(bit);
      payload[k / 8] = static_cast<std::uint8_t>(payload[k / 8] | (1U << (k % 8)));
    }
  }
  return crsf_frame(0x16, payload);
}

inline CanFrame std_frame(std::uint32_t id, const Bytes& data) {
  CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) f.data[i] = data[i];
  return f;
}

inline CanFrame ext_frame(std::uint32_t id, const Bytes& data) {
  CanFrame f = std_frame(id, data);
  f.extended = true;
  return f;
}

/// SET_RPM to controller `id` read by hand: extended id (3 << 8) | id, DLC 4, int32 big-endian.
inline std::optional<std::int32_t> set_rpm_of(const CanFrame& f, std::uint8_t id) {
  if (!f.extended || f.id != ((3U << 8) | id) || f.dlc != 4) return std::nullopt;
  const std::uint32_t u = (static_cast<std::uint32_t>(f.data[0]) << 24) | (static_cast<std::uint32_t>(f.data[1]) << 16) |
                          (static_cast<std::uint32_t>(f.data[2]) << 8) | f.data[3];
  return static_cast<std::int32_t>(u);
}

inline std::string hex(const Bytes& b) {
  static const char* digits = "0123456789ABCDEF";
  std::string s;
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (i) s += ' ';
    s += digits[b[i] >> 4];
    s += digits[b[i] & 15];
  }
  return s;
}

inline std::string candump(const CanFrame& f) {
  std::ostringstream o;
  o << std::hex << std::uppercase;
  o.width(f.extended ? 8 : 3);
  o.fill('0');
  o << f.id << '#';
  for (std::size_t i = 0; i < f.dlc; ++i) {
    o.width(2);
    o << static_cast<unsigned>(f.data[i]);
  }
  return o.str();
}

/// Finds every complete inter-board frame in a byte log by hand (start byte, length, CRC), for the checks.
struct IbFrame {
  std::uint8_t type = 0;
  Bytes payload;
};
inline std::vector<IbFrame> split_ib(const Bytes& log) {
  std::vector<IbFrame> out;
  std::size_t i = 0;
  while (i + 4 <= log.size()) {
    if (log[i] != 0xAA) {
      ++i;
      continue;
    }
    const std::size_t len = log[i + 1];
    if (i + 4 + len > log.size()) break;
    Bytes covered(log.begin() + static_cast<std::ptrdiff_t>(i + 2), log.begin() + static_cast<std::ptrdiff_t>(i + 3 + len));
    if (crc8_maxim(covered) != log[i + 3 + len]) {
      ++i;
      continue;
    }
    out.push_back({covered[0], Bytes(covered.begin() + 1, covered.end())});
    i += 4 + len;
  }
  return out;
}

// ---- fakes --------------------------------------------------------------------------------------------------------

struct FakeSerial final : SerialPort {
  std::deque<std::uint8_t> rx;
  Bytes tx;
  std::size_t read(std::span<std::uint8_t> out) override {
    std::size_t n = 0;
    while (n < out.size() && !rx.empty()) {
      out[n++] = rx.front();
      rx.pop_front();
    }
    return n;
  }
  std::size_t write(std::span<const std::uint8_t> data) override {
    tx.insert(tx.end(), data.begin(), data.end());
    return data.size();
  }
  /// The transmit buffer's size as write_room() tells it (the loop trace writes whole records into the room only).
  std::size_t tx_limit = static_cast<std::size_t>(-1);
  std::size_t write_room() override { return tx.size() < tx_limit ? tx_limit - tx.size() : 0; }
  void feed(const Bytes& b) { rx.insert(rx.end(), b.begin(), b.end()); }
  void feed(const std::string& s) { rx.insert(rx.end(), s.begin(), s.end()); }
  std::string text() const { return std::string(tx.begin(), tx.end()); }
};

struct FakeCan final : CanPort {
  std::deque<CanFrame> rx;
  std::vector<CanFrame> tx;
  console::CanStats counters{};
  bool receive(CanFrame& out) override {
    if (rx.empty()) return false;
    out = rx.front();
    rx.pop_front();
    return true;
  }
  bool send(const CanFrame& f) override {
    tx.push_back(f);
    return true;
  }
  console::CanStats stats() override { return counters; }
};

struct FakeImu final : Imu {
  std::deque<ImuSample> queue;
  bool read(ImuSample& out) override {
    if (queue.empty()) return false;
    out = queue.front();
    queue.pop_front();
    return true;
  }
};

struct FakeWatchdog final : Watchdog {
  TimeUs now = 0;
  TimeUs last_feed = 0;
  std::uint64_t feeds = 0;
  void feed() override {
    ++feeds;
    last_feed = now;
  }
};

struct FakeDisplay final : Display {
  LcdView last{};
  int shows = 0;
  void show(const LcdView& v) override {
    last = v;
    ++shows;
  }
};

struct FakePwm final : Pwm {
  std::array<std::uint16_t, kPwmChannelCount> value{};
  std::vector<std::pair<PwmChannel, std::uint16_t>> log;  // cleared by the rig at every step
  void set(PwmChannel c, std::uint16_t permille) override {
    value[static_cast<std::size_t>(c)] = permille;
    log.emplace_back(c, permille);
  }
  std::uint16_t operator[](PwmChannel c) const { return value[static_cast<std::size_t>(c)]; }
};

struct FakeGpio final : Gpio {
  std::array<bool, kOutputPinCount> out{};
  bool button = false;
  bool kill = false;
  std::vector<std::pair<OutputPin, bool>> log;
  void write(OutputPin p, bool on) override {
    out[static_cast<std::size_t>(p)] = on;
    log.emplace_back(p, on);
  }
  bool read(InputPin p) override { return p == InputPin::arm_button ? button : kill; }
  bool operator[](OutputPin p) const { return out[static_cast<std::size_t>(p)]; }
};

struct FakeHorn final : Horn {
  std::uint16_t hz = 0;
  void tone(std::uint16_t f) override { hz = f; }
};

struct FakeLeds final : LedStrip {
  std::vector<Rgb> pixels;
  int frames = 0;
  void show(std::span<const Rgb> p) override {
    pixels.assign(p.begin(), p.end());
    ++frames;
  }
};

struct FakeSensors final : Sensors {
  SensorReadings readings{};
  int reads = 0;
  SensorReadings read() override {
    ++reads;
    return readings;
  }
};

/// An IMU sample at a pitch (nose up, degrees) and pitch rate, in the body frame of hal.hpp.
inline ImuSample imu_at(TimeUs t, float pitch_deg, float rate_dps = 0.0F) {
  const float r = pitch_deg * 3.14159265358979F / 180.0F;
  ImuSample s;
  s.t_us = t;
  s.ax = std::sin(r);
  s.az = std::cos(r);
  s.gy = -rate_dps;
  return s;
}

// ---- BALANCE rig ----------------------------------------------------------------------------------------------------

/// One BALANCE board with an IO board, an Orin and two VESCs faked around it. Each tick is 1 ms and one step().
struct BalanceRig {
  FakeImu imu;
  FakeCan can;
  FakeSerial link;
  FakeSerial console;
  FakeWatchdog watchdog;
  FakeDisplay display;
  RetainedLimits retained{};  // what a reset keeps (RTC memory on the board)
  BalanceConfig config{};
  std::optional<BalanceBoard> board;
  TimeUs now = 1'000'000;  // boards boot at an arbitrary non-zero time

  // the simulated world
  float pitch = 0.0F;      // truth, degrees
  float rate = 0.0F;
  bool imu_on = true;
  bool io_on = true;       // IO board sends RC_CMD every 10 ms and FAULT every 100 ms
  interboard::RcCmd rc{};  // what it sends
  std::uint8_t io_faults = 0;
  bool orin_on = false;    // Orin sends 0x300 every 50 ms
  saulcan::VelocityCmd velocity{};
  TimeUs next_rc = 0;
  TimeUs next_fault = 0;
  TimeUs next_orin = 0;
  TimeUs last_imu_us = 0;

  explicit BalanceRig(const BalanceConfig& c = {}, ResetReason reset = ResetReason::power_on) : config(c) {
    boot(reset);
  }

  void boot(ResetReason reset) {
    board.emplace(BalanceBoard::Hardware{imu, can, link, console, watchdog, display, retained}, config, reset);
    next_rc = next_fault = next_orin = now;
  }

  Bytes encoded(const interboard::Message& m) {
    std::uint8_t buf[interboard::kMaxFrameSize];
    const auto n = interboard::encode(m, buf);
    return Bytes(buf, buf + *n);
  }
  // what the fake IO board has sent, for the oracles of the invariant tests
  std::uint64_t rc_sent_unarmed = 0;   // RC_CMDs with the armed flag clear
  std::uint64_t rc_sent_kill = 0;      // RC_CMDs with the kill flag
  std::uint64_t fault_sent_estop = 0;  // FAULTs with the estop bit
  TimeUs last_rc_sent = 0;
  bool rc_ever_sent = false;
  bool last_rc_kill = false;       // the kill flag of the newest RC_CMD sent
  bool last_fault_estop = false;   // the estop bit of the newest FAULT sent

  void send_rc(const interboard::RcCmd& m) {
    link.feed(encoded(m));
    if (!m.armed()) ++rc_sent_unarmed;
    if (m.kill()) ++rc_sent_kill;
    last_rc_sent = now;
    rc_ever_sent = true;
    last_rc_kill = m.kill();
  }
  void send_fault(std::uint8_t flags) {
    link.feed(encoded(interboard::Fault{flags}));
    if (flags & interboard::Fault::kEstop) ++fault_sent_estop;
    last_fault_estop = (flags & interboard::Fault::kEstop) != 0;
  }

  /// Inputs due at `now`, then one step.
  TimeUs step_us = 1000;   // one step() per tick; the IMU still delivers one sample per millisecond

  void tick() {
    inputs(step_us);
    watchdog.now = now;
    board->step(now);
  }
  /// Time passes and the world sends what it sends, but the board does not run (a hung loop).
  void idle(TimeUs us) {
    inputs(us);
    while (imu.queue.size() > 16) imu.queue.pop_front();  // the IMU's FIFO keeps the newest samples
  }
  void inputs(TimeUs us) {
    for (TimeUs t = now + 1000; t <= now + us; t += 1000)
      if (imu_on) {
        imu.queue.push_back(imu_at(t, pitch, rate));
        last_imu_us = t;
      }
    now += us;
    if (io_on && now >= next_fault) {
      send_fault(io_faults);
      next_fault = now + 100'000;
    }
    if (io_on && now >= next_rc) {
      send_rc(rc);
      next_rc = now + 10'000;
    }
    if (orin_on && now >= next_orin) {
      can.rx.push_back(saulcan::encode(velocity));
      next_orin = now + 50'000;
    }
  }
  void run_ms(int ms) {
    const auto n = static_cast<TimeUs>(ms) * 1000 / step_us;
    for (TimeUs i = 0; i < n; ++i) tick();
  }

  /// The IO board's fresh arming: armed flag 0, then 1 on the next RC_CMD. Leaves rc.flags armed.
  void arm_via_io() {
    rc.flags = 0;
    send_rc(rc);
    run_ms(2);
    rc.flags = interboard::RcCmd::kArmed;
    send_rc(rc);
    run_ms(2);
  }

  void type(const std::string& line) { console.feed(line + "\n"); }
  std::string reply_to(const std::string& line) {
    console.tx.clear();
    type(line);
    tick();
    return console.text();
  }

  /// SET_RPM values (left, right) sent since frame index `from`.
  std::vector<std::pair<std::int32_t, std::int32_t>> wheels_since(std::size_t from) const {
    std::vector<std::pair<std::int32_t, std::int32_t>> out;
    std::int32_t left = 0x7FFFFFFF;  // none yet (a plain value: GCC 12 -O1 misreads an optional here)
    for (std::size_t i = from; i < can.tx.size(); ++i) {
      if (auto l = set_rpm_of(can.tx[i], 68)) left = *l;
      if (auto r = set_rpm_of(can.tx[i], 56)) {
        out.emplace_back(left, *r);
        left = 0x7FFFFFFF;
      }
    }
    return out;
  }
  /// The last SET_RPM pair sent.
  std::pair<std::int32_t, std::int32_t> last_wheels() const {
    const auto w = wheels_since(0);
    return w.empty() ? std::make_pair(INT32_MIN, INT32_MIN) : w.back();
  }
  std::vector<CanFrame> frames_with_id(std::uint32_t id, std::size_t from = 0) const {
    std::vector<CanFrame> out;
    for (std::size_t i = from; i < can.tx.size(); ++i)
      if (!can.tx[i].extended && can.tx[i].id == id) out.push_back(can.tx[i]);
    return out;
  }
};

// ---- IO rig -------------------------------------------------------------------------------------------------------

/// One IO board with two receivers, a BALANCE board (sending STATE) and its switches faked around it.
struct IoRig {
  FakeSerial crsf;
  FakeSerial elrs;
  FakeSerial link;
  FakeSerial console;
  FakePwm pwm;
  FakeGpio gpio;
  FakeHorn horn;
  FakeLeds leds;
  FakeSensors sensors;
  FakeWatchdog watchdog;
  IoConfig config{};
  std::optional<IoBoard> board;
  TimeUs now = 1'000'000;

  // the simulated world
  std::array<std::uint16_t, 16> sticks{};  // microseconds, index 0 = CH1
  bool crsf_on = true;                     // the Crossfire receiver sends a frame every 4 ms (250 Hz)
  bool elrs_on = false;                    // the ELRS receiver likewise
  bool balance_on = true;                  // BALANCE sends STATE every 20 ms
  interboard::State state{0, 0, 0};
  std::optional<std::uint8_t> speed_cap;   // and after it SPEED_CAP with this percentage (none: not sent)
  TimeUs next_crsf = 0;
  TimeUs next_elrs = 0;
  TimeUs next_state = 0;
  TimeUs step_us = 1000;

  // what the fake receivers and BALANCE delivered last, for the oracles
  struct Delivered {
    TimeUs at = 0;
    std::array<std::uint16_t, 16> us{};
    bool seen = false;
    Delivered() = default;
    Delivered(TimeUs t, const std::array<std::uint16_t, 16>& s) : at(t), us(s), seen(true) {}
  };
  struct StateDelivered {
    TimeUs at = 0;
    interboard::State state{};
    bool seen = false;
    StateDelivered() = default;
    StateDelivered(TimeUs t, const interboard::State& s) : at(t), state(s), seen(true) {}
  };
  Bytes frame;
  std::array<std::uint16_t, 16> frame_sticks{};
  Delivered crsf_last{};
  Delivered elrs_last{};
  StateDelivered state_last{};
  /// A receiver is alive while its last frame is at most 100 ms old.
  bool alive(const Delivered& d) const { return d.seen && now - d.at <= 100'000; }

  explicit IoRig(const IoConfig& c = {}) : config(c) {
    sticks.fill(1500);
    sticks[4] = 1000;  // ARM switch off
    sticks[5] = 1000;  // ESTOP normal
    sticks[6] = 988;   // speed cap 10 %
    board.emplace(IoBoard::Hardware{crsf, elrs, link, console, pwm, gpio, horn, leds, sensors, watchdog}, config);
    next_crsf = next_elrs = next_state = now;
  }

  void send_state(const interboard::State& s) {
    std::uint8_t buf[interboard::kMaxFrameSize];
    const auto n = interboard::encode(s, buf);
    link.feed(Bytes(buf, buf + *n));
  }

  void tick() {
    now += step_us;
    if ((crsf_on && now >= next_crsf) || (elrs_on && now >= next_elrs)) {
      if (sticks != frame_sticks || frame.empty()) {  // packing by hand is slow: once per change of the sticks
        frame = crsf_rc_frame(sticks);
        frame_sticks = sticks;
      }
    }
    if (crsf_on && now >= next_crsf) {
      crsf.feed(frame);
      crsf_last = {now, sticks};
      next_crsf = now + 4000;
    }
    if (elrs_on && now >= next_elrs) {
      elrs.feed(frame);
      elrs_last = {now, sticks};
      next_elrs = now + 4000;
    }
    if (balance_on && now >= next_state) {
      send_state(state);
      if (speed_cap) {
        std::uint8_t buf[interboard::kMaxFrameSize];
        const auto n = interboard::encode(interboard::SpeedCap{*speed_cap}, buf);
        link.feed(Bytes(buf, buf + *n));
      }
      state_last = {now, state};
      next_state = now + 20'000;
    }
    pwm.log.clear();
    gpio.log.clear();
    watchdog.now = now;
    board->step(now);
  }
  void run_ms(int ms) {
    const int n = static_cast<int>(static_cast<TimeUs>(ms) * 1000 / step_us);
    for (int i = 0; i < n; ++i) tick();
  }

  /// Holds the arming button for 3 s in 50 ms steps (the logic only compares timestamps, so the hold is the same),
  /// then releases it and reports BALANCE armed, as the real BALANCE would after the rising flag.
  /// The throttle stick is centred for the hold (arming needs it) and put back afterwards.
  bool arm_quickly() {
    const TimeUs step = step_us;
    const std::uint16_t throttle = sticks[1];
    sticks[1] = 1500;
    step_us = 50'000;
    gpio.button = true;
    for (int i = 0; i < 61 && !board->armed(); ++i) tick();
    gpio.button = false;
    sticks[1] = throttle;
    step_us = step;
    state.error_state = 1;
    run_ms(25);
    return board->armed();
  }

  bool motors_off() const {
    return pwm[PwmChannel::left_rpwm] == 0 && pwm[PwmChannel::left_lpwm] == 0 && pwm[PwmChannel::right_rpwm] == 0 &&
           pwm[PwmChannel::right_lpwm] == 0 && !gpio[OutputPin::left_r_en] && !gpio[OutputPin::left_l_en] &&
           !gpio[OutputPin::right_r_en] && !gpio[OutputPin::right_l_en];
  }

  std::vector<IbFrame> link_frames() const { return split_ib(link.tx); }
  std::string reply_to(const std::string& line) {
    console.tx.clear();
    console.feed(line + "\n");
    tick();
    return console.text();
  }
};

// ---- randomized scenarios -----------------------------------------------------------------------------------------

/// Scenarios per invariant: SAUL_FW_SCENARIOS, default 10000. SAUL_FW_SEED=<n> runs only scenario seed n.
inline int scenario_count() {
  if (const char* s = std::getenv("SAUL_FW_SEED"); s != nullptr && *s) return 1;
  if (const char* s = std::getenv("SAUL_FW_SCENARIOS"); s != nullptr && *s) return std::atoi(s);
  return 10000;
}
inline std::uint64_t scenario_seed(std::uint64_t base, int i) {
  if (const char* s = std::getenv("SAUL_FW_SEED"); s != nullptr && *s) return std::strtoull(s, nullptr, 0);
  return base * 1'000'003ULL + static_cast<std::uint64_t>(i);
}

/// A small, fully specified generator (splitmix64), so a seed replays the same scenario on every platform.
struct Rng {
  std::uint64_t state;
  explicit Rng(std::uint64_t seed) : state(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  /// 0..n-1
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : next() % n; }
  std::int64_t range(std::int64_t lo, std::int64_t hi) {
    return lo + static_cast<std::int64_t>(below(static_cast<std::uint64_t>(hi - lo + 1)));
  }
  bool chance(unsigned percent) { return below(100) < percent; }
  float uniform(float lo, float hi) { return lo + (hi - lo) * static_cast<float>(below(1'000'001)) / 1'000'000.0F; }
};

/// The event trace of one scenario, printed with its seed when an invariant breaks.
struct Trace {
  std::uint64_t seed = 0;
  std::vector<std::string> events;
  void add(TimeUs t, const std::string& what) {
    if (events.size() < 400) events.push_back("t=" + std::to_string(t / 1000) + "ms " + what);
  }
  std::string dump() const {
    std::string s = "seed " + std::to_string(seed) + " (replay: SAUL_FW_SEED=" + std::to_string(seed) + ")\n";
    for (const auto& e : events) s += "  " + e + "\n";
    return s;
  }
};

}  // namespace fwtest
