// Ethernet side of the pose link: a TCP server that streams frames to several clients and hands
// what they send to a TcpInput (the robot's requests), a UDP sender (one frame per datagram), and
// the client ends used by `edgefuse listen`. Sockets are non-blocking; sending never allocates and
// never waits for a slow client (it drops the frame for that client and resynchronises its stream
// with the server's resync byte, 0x00 for frames or '\n' for text lines, before the next one).
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

//! Receives what a TcpServer's clients send.
class TcpInput {
 public:
  virtual ~TcpInput() = default;
  //! \param client the client's slot  \param data bytes received  \param n their number
  virtual void received(int client, const uint8_t* data, size_t n) = 0;
  //! The client in this slot hung up or was dropped (its partial input is void). \param client the slot
  virtual void closed(int client) = 0;
};

class TcpServer {
 public:
  static constexpr int kMaxClients = 8;
  //! Bytes read from one client per service() call at most, so a flooding client cannot starve
  //! the loop (the rest waits for the next call).
  static constexpr size_t kReadPerServiceMax = 4096;

  //! \param resync_byte sent before the next message after one was cut short for a slow client
  explicit TcpServer(uint8_t resync_byte = 0) : resync_byte_(resync_byte) {}

  ~TcpServer() { close(); }
  //! Listens on host:port (port 0: any free port, see port()).
  //! \param host  address to bind ("" or "0.0.0.0": all interfaces)
  //! \param port  0..65535
  //! \param err   set on failure
  bool listen(const char* host, int port, std::string& err);
  void close();
  //! Accepts waiting clients (beyond kMaxClients they are refused), hands what clients sent to
  //! the input (discarded without one), drops clients that hung up. Call when listen_fd() or a
  //! client is readable.
  void service();
  //! \param in receives the clients' bytes (null: discarded)
  void set_input(TcpInput* in) { input_ = in; }
  //! Sends one message to one client, never waiting (dropped, counted, when its socket is full).
  //! \param client the slot  \param data the bytes  \param len their number  \return false if dropped
  bool send_to(int client, const uint8_t* data, size_t len);
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
    bool resync = false;  // a frame was cut short: send the resync byte first
  };
  void drop_client(int i);
  void read_client(int i);
  uint8_t resync_byte_ = 0;
  TcpInput* input_ = nullptr;
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
