// termios2 from the kernel headers: the only way to set an arbitrary baud rate
// (BOTHER). This file must not include <termios.h>.
#include "rtukit/io/serial_config.hpp"

#include <asm/termbits.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>

namespace rtukit::io {
namespace {

Error os_error() {
  return Error(Errc::io_error, errno);
}

speed_t standard_rate(uint32_t baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    case 576000:
      return B576000;
    case 921600:
      return B921600;
    default:
      return 0;
  }
}

// termios2 where the kernel takes it; the classic TCGETS/TCSETS where it
// does not (qemu-user, which runs the aarch64 build's tests, has no
// termios2): the same flags, and the standard rates, which is all a pty or a
// UART at 1200..921600 baud needs. A non-standard rate there is refused.
bool no_termios2(int err) {
  return err == ENOSYS || err == ENOTTY || err == EINVAL;
}

// The fields termios and termios2 share (termios2 adds the two speeds).
template <class From, class To>
void copy_flags(const From& from, To& to) {
  to.c_iflag = from.c_iflag;
  to.c_oflag = from.c_oflag;
  to.c_cflag = from.c_cflag;
  to.c_lflag = from.c_lflag;
  to.c_line = from.c_line;
  for (size_t i = 0; i < sizeof from.c_cc && i < sizeof to.c_cc; ++i) to.c_cc[i] = from.c_cc[i];
}

int get_termios(int fd, struct termios2& tio) {
  if (ioctl(fd, TCGETS2, &tio) == 0) return 0;
  if (!no_termios2(errno)) return -1;
  struct termios old {};
  if (ioctl(fd, TCGETS, &old) != 0) return -1;
  tio = {};
  copy_flags(old, tio);
  return 0;
}

int set_termios(int fd, const struct termios2& tio) {
  if (ioctl(fd, TCSETS2, &tio) == 0) return 0;
  if (!no_termios2(errno)) return -1;
  const int err = errno;
  if ((tio.c_cflag & CBAUD) == BOTHER) return errno = err, -1;  // a rate only termios2 can set
  struct termios old {};
  copy_flags(tio, old);
  return ioctl(fd, TCSETS, &old);
}

}  // namespace

Error make_raw(int fd) {
  struct termios2 tio {};
  if (get_termios(fd, tio) != 0) return os_error();
  tio.c_iflag &=
      ~static_cast<tcflag_t>(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON | IXOFF);
  tio.c_oflag &= ~static_cast<tcflag_t>(OPOST);
  tio.c_lflag &= ~static_cast<tcflag_t>(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
  tio.c_cflag |= CREAD | CLOCAL;
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (set_termios(fd, tio) != 0) return os_error();
  return {};
}

Result<SerialCapabilities> configure_serial(int fd, const SerialSettings& s) {
  SerialCapabilities caps;
  // TIOCEXCL refuses other openers, except root (CAP_SYS_ADMIN bypasses it);
  // the advisory lock also holds against root among programs that take it
  // (rtukit, pyserial with exclusive=True).
  if (ioctl(fd, TIOCEXCL) != 0) return os_error();
  if (flock(fd, LOCK_EX | LOCK_NB) != 0)
    return errno == EWOULDBLOCK ? Error(Errc::io_error, EBUSY) : os_error();
  if (Error e = make_raw(fd)) return e;

  struct termios2 tio {};
  if (get_termios(fd, tio) != 0) return os_error();
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS | CBAUD);
  tio.c_cflag |= (s.data_bits == 7 ? CS7 : CS8) | CREAD | CLOCAL;
  if (s.parity != 'N') tio.c_cflag |= PARENB;
  if (s.parity == 'O') tio.c_cflag |= PARODD;
  if (s.stop_bits == 2) tio.c_cflag |= CSTOPB;
  tio.c_iflag &= ~static_cast<tcflag_t>(INPCK);
  if (s.parity != 'N') tio.c_iflag |= INPCK;
  const speed_t rate = standard_rate(s.baud);
  if (rate != 0) {
    tio.c_cflag |= rate;
    tio.c_ispeed = tio.c_ospeed = s.baud;
  } else {
    tio.c_cflag |= BOTHER;
    tio.c_ispeed = tio.c_ospeed = s.baud;
  }
  if (set_termios(fd, tio) != 0) return os_error();

  if (s.rs485.enabled) {
    struct serial_rs485 rs {};
    rs.flags = SER_RS485_ENABLED;
    if (s.rs485.rts_on_send) rs.flags |= SER_RS485_RTS_ON_SEND;
    if (s.rs485.rts_after_send) rs.flags |= SER_RS485_RTS_AFTER_SEND;
    rs.delay_rts_before_send = (s.rs485.delay_before_us + 999) / 1000;
    rs.delay_rts_after_send = (s.rs485.delay_after_us + 999) / 1000;
    caps.kernel_rs485 = ioctl(fd, TIOCSRS485, &rs) == 0;  // ENOTTY: driver lacks it
  }
  if (s.low_latency) {
    struct serial_struct ss {};
    if (ioctl(fd, TIOCGSERIAL, &ss) == 0) {
      ss.flags |= ASYNC_LOW_LATENCY;
      caps.low_latency = ioctl(fd, TIOCSSERIAL, &ss) == 0;
    }
  }
  // Input only. This also runs on a port in use, to change its baud rate
  // right after an answer: tcdrain() returns before the last byte has left
  // on a pty (the peer may not have read it yet) and on USB adapters whose
  // chip still holds it in its FIFO, and an output flush then throws the
  // answer away (socat pair: 6-8 answers in 20 lost to baud-rate writes).
  ioctl(fd, TCFLSH, TCIFLUSH);
  return caps;
}

Result<int> open_serial_port(const std::string& path, const SerialSettings& settings) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return os_error();
  const Result<SerialCapabilities> caps = configure_serial(fd, settings);
  if (!caps.ok()) {
    ::close(fd);
    return caps.error();
  }
  return fd;
}

Error set_rts(int fd, bool on) {
  int bits = TIOCM_RTS;
  if (ioctl(fd, on ? TIOCMBIS : TIOCMBIC, &bits) != 0) return os_error();
  return {};
}

Error drain(int fd) {
  // TCSBRK with a non-zero argument is tcdrain().
  if (ioctl(fd, TCSBRK, 1) != 0) return os_error();
  return {};
}

// Asked before the port is taken for use (TIOCEXCL, flock): the answer
// depends on the driver, not on the port's settings.
bool kernel_rs485_available(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) return false;
  serial_rs485 rs{};
  const bool available = ::ioctl(fd, TIOCGRS485, &rs) == 0;
  ::close(fd);
  return available;
}

}  // namespace rtukit::io
