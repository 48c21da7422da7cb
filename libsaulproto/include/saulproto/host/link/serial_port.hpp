// Serial ports: the boards' USB consoles, the inter-board UART tap, CRSF, the Pride link, slcan adapters.
//
// Two implementations behind one interface: libserialport for real devices (USB identity, modem lines), POSIX
// termios for pseudo-terminals (which lack the sysfs entries and modem-line ioctls libserialport needs).
// SerialBackend::automatic picks termios for /dev/pts/* and anything libserialport cannot find.
// Errors are SerialError exceptions whose message is one line naming the device and the likely fix.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace saul::host {

enum class Parity : std::uint8_t { none, even, odd };

struct SerialSettings {
  std::uint32_t baud = 115200;
  std::uint8_t data_bits = 8;
  Parity parity = Parity::none;
  std::uint8_t stop_bits = 1;
};

/// "8N1", "8E1", ...
std::string to_string(const SerialSettings& s);
/// Parses "8N1" / "8E1" / "7O2" into s (baud untouched); false when malformed.
bool parse_frame_format(const std::string& text, SerialSettings& s);

class SerialError : public std::runtime_error {
 public:
  enum class Kind { not_found, permission, busy, gone, io, config };
  SerialError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  [[nodiscard]] Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

class SerialPort {
 public:
  virtual ~SerialPort() = default;
  /// Reads whatever is available (at most buf.size() bytes), waiting up to timeout for the first byte.
  /// Returns 0 on timeout. Throws SerialError(gone) when the device disappeared.
  virtual std::size_t read(std::span<std::uint8_t> buf, std::chrono::milliseconds timeout) = 0;
  /// Writes all bytes or throws (gone, or io when the port would not take them within timeout).
  virtual void write(std::span<const std::uint8_t> data, std::chrono::milliseconds timeout) = 0;
  /// Sets the DTR and RTS modem lines (a no-op on a pseudo-terminal, which has none).
  virtual void set_modem_lines(bool dtr, bool rts) = 0;
  /// Changes the baud rate of an open port (the ESP bootloader's CHANGE_BAUDRATE needs it without a reopen,
  /// which would toggle the modem lines). Throws SerialError(config) when the driver refuses the rate; the
  /// default is for ports that cannot change it.
  virtual void set_baud(std::uint32_t baud) {
    throw SerialError(SerialError::Kind::config, path() + ": cannot change the baud rate to " + std::to_string(baud));
  }
  [[nodiscard]] virtual const std::string& path() const = 0;
  /// What was requested (a pty silently drops parity, so do not trust a read-back there).
  [[nodiscard]] virtual const SerialSettings& settings() const = 0;
  /// "termios" or "libserialport".
  [[nodiscard]] virtual const char* backend() const = 0;
  /// A descriptor that polls readable when read() has bytes (-1 when there is none): the shared-link owner
  /// waits on it together with its clients' sockets.
  [[nodiscard]] virtual int poll_handle() const { return -1; }
  /// How the port is shared with other saulctl processes (shared_link.hpp): "" when it is not,
  /// "shared with 1 other saulctl", "through saulctl record (pid 77)".
  [[nodiscard]] virtual std::string sharing() const { return {}; }

  void write(const std::string& text, std::chrono::milliseconds timeout) {
    write(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), timeout);
  }
};

enum class SerialBackend : std::uint8_t { automatic, termios, libserialport };

/// Opens a port for this process alone: an advisory lock (flock) and TIOCEXCL hold it, and a port that another
/// process has open is refused with SerialError(busy) naming it ("/dev/ttyACM0 is held by minicom (pid 4121)",
/// device_holders.hpp). Verbs that can share a device with other saulctl processes open it through
/// shared_link.hpp instead.
std::unique_ptr<SerialPort> open_serial(const std::string& path, const SerialSettings& settings,
                                        SerialBackend backend = SerialBackend::automatic);

/// A serial port as the system sees it, with what we recognise it to be.
struct PortInfo {
  std::string path;
  std::string description;
  std::string manufacturer;
  std::string product;
  std::string serial_number;
  int usb_vid = -1;
  int usb_pid = -1;
  std::string role;  ///< e.g. "CANable2 (slcan firmware)", "ESP32-S3 USB-Serial/JTAG (IO board)", or empty
};

/// Lists serial ports via libserialport (real devices only; ptys are not listed).
std::vector<PortInfo> list_serial_ports();

}  // namespace saul::host
