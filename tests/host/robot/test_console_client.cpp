// The console client's reply reader against a port of the test's own: replies split anywhere, the echo left out, and
// a device that streams bytes without a line end held to a bounded buffer.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <string>

#include "saulproto/host/link/serial_port.hpp"
#include "saulproto/host/robot/console_client.hpp"

using namespace saul::host;
using namespace std::chrono;

namespace {

/// Hands out `text` a few bytes per read, then `flood` bytes of 'x' (no line end) when asked for them.
class ScriptedPort final : public SerialPort {
 public:
  std::string text;
  std::size_t flood = 0;
  std::size_t chunk = 3;
  std::size_t read(std::span<std::uint8_t> buf, milliseconds) override {
    if (at_ < text.size()) {
      const std::size_t n = std::min({chunk, buf.size(), text.size() - at_});
      std::memcpy(buf.data(), text.data() + at_, n);
      at_ += n;
      return n;
    }
    const std::size_t n = std::min(flood, buf.size());
    std::memset(buf.data(), 'x', n);
    flood -= n;
    return n;
  }
  void write(std::span<const std::uint8_t>, milliseconds) override {}
  void set_modem_lines(bool, bool) override {}
  [[nodiscard]] const std::string& path() const override { return path_; }
  [[nodiscard]] const SerialSettings& settings() const override { return settings_; }
  [[nodiscard]] const char* backend() const override { return "scripted"; }

 private:
  std::size_t at_ = 0;
  std::string path_ = "scripted";
  SerialSettings settings_;
};

}  // namespace

TEST_CASE("console client: a reply split across reads, its echo left out, ended by ok or error:") {
  ScriptedPort port;
  port.text = "status\r\nreport=status board=balance state=OFF\r\nok\r\nnext";
  std::string pending;
  const auto r = read_console_reply(port, "status", seconds(1), pending, [] { return false; });
  CHECK(r.end == ConsoleReply::End::ok);
  REQUIRE(r.lines.size() == 1);
  CHECK(r.lines[0] == "report=status board=balance state=OFF");
  CHECK(pending == "");  // "next" not read yet: the reply ended at ok

  ScriptedPort refusing;
  refusing.text = "pid 1 2 3\nerror: not in OFF\n";
  std::string rest;
  const auto e = read_console_reply(refusing, "pid 1 2 3", seconds(1), rest, [] { return false; });
  CHECK(e.end == ConsoleReply::End::error);
  CHECK(e.final_line == "error: not in OFF");
}

TEST_CASE("console client: bytes without a line end (a wrong port or baud) never grow its buffer past 64 KiB") {
  ScriptedPort port;
  port.flood = 1024 * 1024;
  std::string pending;
  std::size_t most = 0;
  const auto r = read_console_reply(port, "status", seconds(1), pending, [&] {
    most = std::max(most, pending.size());
    return port.flood == 0;  // stop when the flood is spent
  });
  CHECK(r.end != ConsoleReply::End::ok);
  CHECK(most <= 64 * 1024 + 512);
}
