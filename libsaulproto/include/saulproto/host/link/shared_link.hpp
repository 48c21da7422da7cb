// One adapter, many saulctl processes.
//
// A serial adapter (an slcan CANable, a board's USB console, a UART tap) has one owner: the first saulctl process
// that opens it holds it exclusively (serial_port.hpp) and serves it to later saulctl processes of the same user
// over a local socket in a private directory (mode 0700: $SAUL_RUNTIME_DIR, else $XDG_RUNTIME_DIR/saulctl, else
// /tmp/saulctl-UID; /dev/ttyACM0 -> ttyACM0.sock, /dev/pts/3 -> pts-3.sock). A later verb on that device goes
// through the owner as if it had opened the device itself:
//  - CAN: every client sees every frame of the bus and the frames any other client (or the owner) sends. An ESTOP
//    (0x302 mode 3) from a client goes before anything else waiting, even through an owner opened listen-only
//    (which then leaves listen-only, and says so).
//  - serial: every client reads every byte the device sends; what a client writes goes to the device.
// Both ends check the other's user (SO_PEERCRED). Confirmation of motion stays with the command, as on a direct link.
// The owner reads the device on a thread of its own and hands each read to its process in one go. A paced owner
// (LinkOpenOptions::paced) with no client stops reading while 2048 frames wait for it, so a burst waits in the
// adapter; otherwise an owner 8192 frames behind loses its oldest, counted.
// When the owner exits, one client takes the device over and the others reconnect to it (each says so in one line);
// when the device disappears, every client ends with the owner's error. A device held by a program that is not
// saulctl is refused with its name and pid (device_holders.hpp).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "saulproto/host/link/can_link.hpp"
#include "saulproto/host/link/link_spec.hpp"
#include "saulproto/host/link/serial_port.hpp"

namespace saul::host {

/// The private directory of the sharing sockets, created 0700 when missing. Throws LinkError(permission) when
/// another user owns it or can enter it.
std::string share_directory();
/// The directory's path without creating or checking it.
std::string share_directory_path();
/// The socket a device is shared on (symlinks resolved first).
std::string share_socket_path(const std::string& device);

/// Who may use a share: the owner's own user only (root is not let into a user's share, nor a user into root's).
bool share_peer_allowed(unsigned peer_uid, unsigned owner_uid);

/// What a share's owner tells about it.
struct ShareInfo {
  int owner_pid = 0;
  std::string owner_command;  ///< "saulctl monitor"
  std::string link;           ///< "slcan:/dev/pts/3@500000", "serial:/dev/ttyACM1@115200:8N1"
  int clients = 0;            ///< other saulctl processes using it now
  [[nodiscard]] std::string owner_text() const;  ///< "saulctl monitor (pid 77)"
};

/// Asks the owner of `device`, if a saulctl process of this user shares it, without joining (doctor). Throws
/// LinkError(permission) when the socket is served by another user.
std::optional<ShareInfo> query_share(const std::string& device);

/// Opens an slcan link shared as described above: joins the owner, or becomes it. `paced`: as LinkOpenOptions::paced.
std::unique_ptr<CanLink> open_shared_slcan(const LinkSpec& spec, bool listen_only,
                                           const std::vector<CanFilter>& filters, bool paced = false);

/// Opens a serial byte link shared as described above.
std::unique_ptr<SerialPort> open_shared_serial(const std::string& path, const SerialSettings& settings);

/// Where the sharing's one-line notices go ("the owner stopped; this saulctl now holds ..."). The default writes
/// "saulctl: <text>" lines on stderr; a full-screen view puts them in its status line instead. Thread-safe.
void set_share_notice(std::function<void(const std::string&)> sink);

}  // namespace saul::host
