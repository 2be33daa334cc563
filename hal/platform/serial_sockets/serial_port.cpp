#include "edgefuse/hal/platform/serial_sockets/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace edgefuse::hal {
namespace {

struct Rate {
  int baud;
  speed_t code;
};
const Rate kRates[] = {{1200, B1200},       {2400, B2400},       {4800, B4800},       {9600, B9600},
                       {19200, B19200},     {38400, B38400},     {57600, B57600},     {115200, B115200},
                       {230400, B230400},   {460800, B460800},   {500000, B500000},   {921600, B921600},
                       {1000000, B1000000}, {1500000, B1500000}, {2000000, B2000000}, {3000000, B3000000},
                       {4000000, B4000000}};

bool speed_of(int baud, speed_t& out) {
  for (const Rate& r : kRates)
    if (r.baud == baud) {
      out = r.code;
      return true;
    }
  return false;
}

}  // namespace

bool baud_supported(int baud) {
  speed_t s;
  return speed_of(baud, s);
}

bool serial_configure(int fd, int baud, std::string& err) {
  speed_t speed;
  if (!speed_of(baud, speed)) {
    err = "unsupported baud rate " + std::to_string(baud);
    return false;
  }
  termios t{};
  if (tcgetattr(fd, &t) != 0) {
    err = std::string("tcgetattr: ") + std::strerror(errno);
    return false;
  }
  cfmakeraw(&t);  // 8 data bits, no parity, no echo, no canonical mode, no CR/LF mapping
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS | PARENB);  // 1 stop bit, no flow control
  t.c_cflag |= CLOCAL | CREAD;
  t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  cfsetispeed(&t, speed);
  cfsetospeed(&t, speed);
  if (tcsetattr(fd, TCSANOW, &t) != 0) {
    err = std::string("tcsetattr: ") + std::strerror(errno);
    return false;
  }
  return true;
}

int serial_open(const char* dev, int baud, std::string& err) {
  const int fd = ::open(dev, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    err = std::string(dev) + ": " + std::strerror(errno);
    return -1;
  }
  std::string e;
  if (!serial_configure(fd, baud, e)) {
    err = std::string(dev) + ": " + e;
    ::close(fd);
    return -1;
  }
  return fd;
}

bool pty_open(PtyPair& pty, std::string& err) {
  pty = PtyPair{};
  const int m = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (m < 0 || grantpt(m) != 0 || unlockpt(m) != 0) {
    err = std::string("pseudo-terminal: ") + std::strerror(errno);
    if (m >= 0) ::close(m);
    return false;
  }
  char name[64];
  if (ptsname_r(m, name, sizeof(name)) != 0) {
    err = std::string("ptsname: ") + std::strerror(errno);
    ::close(m);
    return false;
  }
  const int s = ::open(name, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  std::string e;
  if (s < 0 || !serial_configure(s, 115200, e)) {
    err = std::string(name) + ": " + (s < 0 ? std::strerror(errno) : e.c_str());
    if (s >= 0) ::close(s);
    ::close(m);
    return false;
  }
  pty.controller = m;
  pty.terminal = s;
  std::snprintf(pty.terminal_name, sizeof(pty.terminal_name), "%s", name);
  return true;
}

void pty_close(PtyPair& pty) {
  if (pty.controller >= 0) ::close(pty.controller);
  if (pty.terminal >= 0) ::close(pty.terminal);
  pty = PtyPair{};
}

bool write_all(int fd, const void* data, size_t len, int timeout_ms) {
  const char* p = static_cast<const char*>(data);
  int waited_ms = 0;
  while (len > 0) {
    const ssize_t n = ::write(fd, p, len);
    if (n > 0) {
      p += n;
      len -= size_t(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return false;
    if (waited_ms >= timeout_ms) return false;
    pollfd pfd{fd, POLLOUT, 0};
    ::poll(&pfd, 1, 10);
    waited_ms += 10;
  }
  return true;
}

}  // namespace edgefuse::hal
