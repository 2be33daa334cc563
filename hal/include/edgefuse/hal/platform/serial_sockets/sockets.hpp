// Ethernet side of the pose link: a TCP server that streams frames to several clients, a UDP
// sender (one frame per datagram), and the client ends used by `edgefuse listen`. Sockets are
// non-blocking; sending never allocates and never waits for a slow client (it drops the frame for
// that client and resynchronises its stream with a 0x00 before the next one).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace edgefuse::hal {

//! Splits "HOST:PORT" (HOST may be empty for any address).
//! \param spec  the text
//! \param host  the host part
//! \param port  the port, 1..65535
//! \param err   names the text on failure
bool parse_host_port(const std::string& spec, std::string& host, int& port, std::string& err);

class TcpServer {
 public:
  static constexpr int kMaxClients = 8;

  ~TcpServer() { close(); }
  //! Listens on host:port (port 0: any free port, see port()).
  //! \param host  address to bind ("" or "0.0.0.0": all interfaces)
  //! \param port  0..65535
  //! \param err   set on failure
  bool listen(const char* host, int port, std::string& err);
  void close();
  //! Accepts waiting clients (beyond kMaxClients they are refused) and reads/discards what
  //! clients sent; drops clients that hung up. Call when listen_fd() or a client is readable.
  void service();
  //! Sends one frame to every client.
  //! \param frame bytes of a whole frame (delimiter included)
  //! \param len   their number
  void broadcast(const uint8_t* frame, size_t len);
  int port() const { return port_; }
  int listen_fd() const { return listen_fd_; }
  int client_count() const;
  int client_fd(int i) const { return clients_[i].fd; }
  uint32_t dropped_frames() const { return dropped_; }

 private:
  struct Client {
    int fd = -1;
    bool resync = false;  // a frame was cut short: send 0x00 first
  };
  int listen_fd_ = -1;
  int port_ = 0;
  Client clients_[kMaxClients];
  uint32_t dropped_ = 0;
};

class UdpSender {
 public:
  ~UdpSender() { close(); }
  //! \param host  destination address (IPv4 dotted or a name resolved once here)
  //! \param port  destination port
  //! \param err   set on failure
  bool open(const char* host, int port, std::string& err);
  void close();
  //! Sends one frame as one datagram. \return false if the datagram was not sent
  bool send(const uint8_t* frame, size_t len);

 private:
  int fd_ = -1;
  unsigned char addr_[16] = {};  // sockaddr_in
};

//! A UDP socket bound to `port` on all interfaces (non-blocking). \return fd or -1
int udp_bind(int port, std::string& err);
//! A TCP connection to host:port (blocking connect, then non-blocking). \return fd or -1
int tcp_connect(const char* host, int port, std::string& err);

}  // namespace edgefuse::hal
