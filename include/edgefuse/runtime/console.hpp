// The serial console: a line editor and a static command table (Zephyr shell style). Every reply
// ends with "OK" or "ERR <code> <message>" on a line of its own; garbage, over-long lines and wrong
// arguments give ERR and never block. Bytes in, bytes out: the transport (serial port,
// pseudo-terminal) is the caller's. No heap, no OS calls.
#pragma once

#include <cstddef>

#include "edgefuse/runtime/console_service.hpp"
#include "edgefuse/runtime/params.hpp"

namespace edgefuse::runtime {

class Console {
 public:
  static constexpr size_t kLineMax = 128;  //!< longest accepted line, line end excluded
  static constexpr int kArgsMax = 10;

  //! \param service  does the work
  //! \param params   the parameter table (`param get|set`)
  //! \param out      receives the replies
  //! \param version  `version` prints it
  Console(ConsoleService& service, ParamStore& params, ConsoleWriter& out, const char* version)
      : service_(service), params_(params), out_(out), version_(version) {}

  //! Echo typed characters back (terminal programs do not echo locally).
  void set_echo(bool on) { echo_ = on; }

  //! Feeds received bytes; runs each complete line.
  //! \param data bytes from the terminal
  //! \param n    their number
  void feed(const char* data, size_t n);

  //! Runs one command line (without line end), printing its reply.
  void execute(char* line);

 private:
  void end_of_line();
  CmdResult dispatch(int argc, char** argv);
  void reply(const CmdResult& r);

  ConsoleService& service_;
  ParamStore& params_;
  ConsoleWriter& out_;
  const char* version_;
  char line_[kLineMax + 1] = {};
  size_t len_ = 0;
  bool overflow_ = false;
  bool bad_char_ = false;
  bool echo_ = false;
  bool last_cr_ = false;
};

}  // namespace edgefuse::runtime
