// Non-standard baud rates (CRSF's 420000) need the termios2 interface, whose header clashes with <termios.h>,
// so it lives alone in this file.
#include <asm/termbits.h>
#include <sys/ioctl.h>

#include <cstdint>

namespace saul::host {

bool set_custom_baud(int fd, std::uint32_t baud) {
  struct termios2 t {};
  if (::ioctl(fd, TCGETS2, &t) != 0) return false;
  t.c_cflag &= ~static_cast<tcflag_t>(CBAUD);
  t.c_cflag |= BOTHER;
  t.c_ispeed = baud;
  t.c_ospeed = baud;
  return ::ioctl(fd, TCSETS2, &t) == 0;
}

// The rate the driver really runs at (the kernel keeps it in c_ospeed for every rate), 0 when unknown.
std::uint32_t driver_baud(int fd) {
  struct termios2 t {};
  if (::ioctl(fd, TCGETS2, &t) != 0) return 0;
  return t.c_ospeed;
}

}  // namespace saul::host
