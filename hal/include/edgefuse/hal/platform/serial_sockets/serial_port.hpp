// Serial ports and pseudo-terminals (POSIX termios): raw 8N1 at a chosen baud rate, non-blocking.
// On host-sim the daemon opens pseudo-terminal pairs and names the terminal side so that
// picocom, minicom, screen or `edgefuse listen --serial` can connect.
#pragma once

#include <string>

namespace edgefuse::hal {

//! True if `baud` is a rate termios can set (1200 ... 4000000).
bool baud_supported(int baud);

//! Sets raw 8N1 mode (no echo, no line editing, no flow control, no CR/LF translation).
//! \param fd    an open terminal
//! \param baud  bit rate; pseudo-terminals accept and ignore it
//! \param err   set on failure
bool serial_configure(int fd, int baud, std::string& err);

//! Opens a serial device (or a pseudo-terminal's terminal side) non-blocking, raw 8N1.
//! \param dev   device path, e.g. /dev/ttyS1, /dev/ttyUSB0, /dev/pts/5
//! \param baud  bit rate
//! \param err   names the device on failure
//! \return the file descriptor, or -1
int serial_open(const char* dev, int baud, std::string& err);

//! A pseudo-terminal pair: the program keeps `controller`; a client opens `terminal_name`.
struct PtyPair {
  int controller = -1;          //!< master side, non-blocking, read/written by the program
  int terminal = -1;            //!< slave side, held open so that the pair survives clients leaving
  char terminal_name[64] = {};  //!< /dev/pts/N
};

//! Opens a raw pseudo-terminal pair.
//! \param pty  filled on success
//! \param err  set on failure
bool pty_open(PtyPair& pty, std::string& err);
//! Closes both sides.
void pty_close(PtyPair& pty);

//! Writes all of `len` bytes to a non-blocking fd, waiting for room at most `timeout_ms` in total.
//! \return false if the fd failed or stayed full (the rest is dropped)
bool write_all(int fd, const void* data, size_t len, int timeout_ms);

}  // namespace edgefuse::hal
