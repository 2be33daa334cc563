#include "edgefuse/hal/platform/service/ports.hpp"

#include <unistd.h>

namespace edgefuse::hal {

bool open_port(const char* what, const std::string& spec, int baud, Port& p, std::string& err) {
  if (spec.empty()) return true;
  if (spec == "pty") {
    if (!pty_open(p.pty, err)) return false;
    p.fd = p.pty.controller;
    p.name = p.pty.terminal_name;
    return true;
  }
  if (!baud_supported(baud)) {
    err = std::string(what) + ".baud = " + std::to_string(baud) + " is not a standard rate";
    return false;
  }
  p.fd = serial_open(spec.c_str(), baud, err);
  if (p.fd < 0) return false;
  p.name = spec;
  return true;
}

void close_port(Port& p) {
  if (p.pty.controller >= 0)
    pty_close(p.pty);
  else if (p.fd >= 0)
    ::close(p.fd);
  p.fd = -1;
}

void LinkFanout::send_serial(const uint8_t* frame, size_t len) {
  if (serial_fd < 0) return;
  const uint8_t zero = 0;
  if (serial_resync) serial_resync = !write_all(serial_fd, &zero, 1, 0);
  if (serial_resync || !write_all(serial_fd, frame, len, 0)) {
    ++serial_drops;
    serial_resync = true;
  }
}

void LinkFanout::send(const uint8_t* frame, size_t len) {
  send_serial(frame, len);
  if (tcp != nullptr) tcp->broadcast(frame, len);
  if (udp != nullptr) udp->send(frame, len);
}

}  // namespace edgefuse::hal
