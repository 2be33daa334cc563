// The firmware's byte ports: a serial device (termios), a pseudo-terminal (host-sim: the name is
// printed so a terminal program can attach), or none; and the link's fan-out of frames to the
// serial port, the TCP clients and a UDP destination.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "edgefuse/hal/platform/serial_sockets/serial_port.hpp"
#include "edgefuse/hal/platform/serial_sockets/sockets.hpp"
#include "edgefuse/link/publisher.hpp"

namespace edgefuse::hal {

struct Port {
  PtyPair pty;
  int fd = -1;       //!< what the program reads and writes (-1: off)
  std::string name;  //!< the device or the pseudo-terminal's name
};

//! Opens `spec`: "" (off), "pty" or a serial device at `baud`.
//! \param what the option's section, named in errors ("console", "link")
//! \param spec the option's value  \param baud the rate  \param p the port  \param err why not
bool open_port(const char* what, const std::string& spec, int baud, Port& p, std::string& err);
void close_port(Port& p);

//! Sends every frame to the link's serial port, the TCP clients and the UDP destination. A full
//! serial line (nobody reading, or slower than the results) drops the frame, counted, and the next
//! frame starts with a 0x00 so a receiver resynchronises.
class LinkFanout final : public link::FrameSink {
 public:
  int serial_fd = -1;
  TcpServer* tcp = nullptr;
  UdpSender* udp = nullptr;
  uint32_t serial_drops = 0;
  bool serial_resync = false;  //!< a frame may have gone out cut short: a 0x00 ends it first
  void send(const uint8_t* frame, size_t len) override;
  //! Sends one frame on the serial port alone (a reply to a request that came in on it).
  //! \param frame a whole frame  \param len its length
  void send_serial(const uint8_t* frame, size_t len);
};

}  // namespace edgefuse::hal
