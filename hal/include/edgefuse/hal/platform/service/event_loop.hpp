// The firmware's service loop on the OS: waits (poll, 10 ms at most, so the pipeline's tick also
// runs when nothing arrives) on the console, the link's serial port, the link's TCP server and the
// robot's text port, hands the console's and the link's bytes to the handler (TCP clients' bytes go
// to each server's TcpInput), ticks it, reports readiness and feeds the systemd watchdog, and
// returns when SIGTERM or SIGINT arrives. A console that shares the link's serial port gets the
// bytes read from it; otherwise they are the robot's requests (link_input).
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/hal/platform/serial_sockets/sockets.hpp"

namespace edgefuse::hal {

class ServiceHandler {
 public:
  virtual ~ServiceHandler() = default;
  //! Bytes typed on the console. \param data the bytes  \param n their number
  virtual void console_input(const char* data, size_t n) = 0;
  //! Bytes received on the link's serial port (not shared with the console).
  //! \param data the bytes  \param n their number
  virtual void link_input(const uint8_t* data, size_t n) = 0;
  //! The loop's tick. \param now_us the monotonic clock
  virtual void tick(uint64_t now_us) = 0;
};

struct ServiceSources {
  int console_fd = -1;              //!< the console's port (-1: none)
  int link_fd = -1;                 //!< the link's serial port (-1: none)
  bool console_on_link = false;     //!< the console shares the link's port
  TcpServer* tcp = nullptr;         //!< the link's TCP server (accepts, drops dead clients)
  TcpServer* text = nullptr;        //!< the robot's text port (null: off)
};

//! Serves until SIGTERM or SIGINT. \return the signal that stopped it
int serve_until_signal(const ServiceSources& sources, ServiceHandler& handler);

}  // namespace edgefuse::hal
