#include "edgefuse/hal/platform/serial_sockets/sockets.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace edgefuse::hal {
namespace {

bool resolve(const char* host, int port, sockaddr_in& out, std::string& err) {
  out = sockaddr_in{};
  out.sin_family = AF_INET;
  out.sin_port = htons(uint16_t(port));
  if (host == nullptr || *host == '\0') {
    out.sin_addr.s_addr = htonl(INADDR_ANY);
    return true;
  }
  if (inet_pton(AF_INET, host, &out.sin_addr) == 1) return true;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(host, nullptr, &hints, &res);
  if (rc != 0 || res == nullptr) {
    err = std::string("cannot resolve host '") + host + "': " + gai_strerror(rc);
    return false;
  }
  out.sin_addr = reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr;
  freeaddrinfo(res);
  return true;
}

void set_nonblocking(int fd) { fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK); }

}  // namespace

bool parse_host_port(const std::string& spec, std::string& host, int& port, std::string& err) {
  const size_t colon = spec.rfind(':');
  const std::string p = colon == std::string::npos ? spec : spec.substr(colon + 1);
  host = colon == std::string::npos ? "" : spec.substr(0, colon);
  char* end = nullptr;
  const long v = std::strtol(p.c_str(), &end, 10);
  if (p.empty() || *end != '\0' || v < 1 || v > 65535) {
    err = "'" + spec + "' is not HOST:PORT with a port in [1, 65535]";
    return false;
  }
  port = int(v);
  return true;
}

bool TcpServer::listen(const char* host, int port, std::string& err) {
  close();
  sockaddr_in a;
  if (!resolve(host, port, a, err)) return false;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    err = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  const int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 || ::listen(fd, 4) != 0) {
    err = "TCP port " + std::to_string(port) + ": " + std::strerror(errno);
    ::close(fd);
    return false;
  }
  socklen_t n = sizeof(a);
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
  port_ = ntohs(a.sin_port);
  listen_fd_ = fd;
  return true;
}

void TcpServer::close() {
  for (Client& c : clients_) {
    if (c.fd >= 0) ::close(c.fd);
    c = Client{};
  }
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
}

int TcpServer::client_count() const {
  int n = 0;
  for (const Client& c : clients_) n += c.fd >= 0;
  return n;
}

void TcpServer::service() {
  if (listen_fd_ < 0) return;
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) break;
    Client* slot = nullptr;
    for (Client& c : clients_)
      if (c.fd < 0) {
        slot = &c;
        break;
      }
    if (slot == nullptr) {
      ::close(fd);  // full: refuse rather than slow everybody down
      continue;
    }
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));  // a pose is latency-critical
    *slot = Client{fd, false};
  }
  for (int i = 0; i < kMaxClients; ++i)
    if (clients_[i].fd >= 0) read_client(i);
}

void TcpServer::drop_client(int i) {
  ::close(clients_[i].fd);
  clients_[i] = Client{};
  if (input_ != nullptr) input_->closed(i);
}

// Hands what the client sent to the input (at most kReadPerServiceMax bytes), notices hang-ups.
void TcpServer::read_client(int i) {
  uint8_t buf[512];
  for (size_t total = 0; total < kReadPerServiceMax;) {
    const ssize_t n = ::recv(clients_[i].fd, buf, sizeof(buf), 0);
    if (n > 0) {
      if (input_ != nullptr) input_->received(i, buf, size_t(n));
      total += size_t(n);
      continue;
    }
    if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) drop_client(i);
    return;
  }
}

// One client: the resync byte first when its last message went out cut short. \return sent whole
static bool send_one(int fd, bool& resync, uint8_t resync_byte, const uint8_t* data, size_t len, bool& dead) {
  dead = false;
  if (resync) {
    if (::send(fd, &resync_byte, 1, MSG_NOSIGNAL | MSG_DONTWAIT) != 1) return false;
    resync = false;
  }
  const ssize_t n = ::send(fd, data, len, MSG_NOSIGNAL | MSG_DONTWAIT);
  if (n == ssize_t(len)) return true;
  dead = n < 0 && errno != EAGAIN && errno != EWOULDBLOCK;
  resync = n > 0;  // part of a message went out: the receiver discards it at the resync byte
  return false;
}

bool TcpServer::send_to(int client, const uint8_t* data, size_t len) {
  Client& c = clients_[client];
  if (c.fd < 0) return false;
  bool dead = false;
  if (send_one(c.fd, c.resync, resync_byte_, data, len, dead)) return true;
  if (dead)
    drop_client(client);
  else
    ++dropped_;
  return false;
}

void TcpServer::broadcast(const uint8_t* frame, size_t len) {
  for (int i = 0; i < kMaxClients; ++i)
    if (clients_[i].fd >= 0) send_to(i, frame, len);
}

bool UdpSender::open(const char* host, int port, std::string& err) {
  close();
  static_assert(sizeof(addr_) >= sizeof(sockaddr_in), "room for an IPv4 address");
  sockaddr_in a;
  if (!resolve(host, port, a, err)) return false;
  std::memcpy(addr_, &a, sizeof(a));
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    err = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  const int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_BROADCAST, &one, sizeof(one));
  return true;
}

void UdpSender::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool UdpSender::send(const uint8_t* frame, size_t len) {
  if (fd_ < 0) return false;
  return ::sendto(fd_, frame, len, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(addr_), sizeof(sockaddr_in)) ==
         ssize_t(len);
}

int udp_bind(int port, std::string& err) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    err = std::string("socket: ") + std::strerror(errno);
    return -1;
  }
  const int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0) {
    err = "UDP port " + std::to_string(port) + ": " + std::strerror(errno);
    ::close(fd);
    return -1;
  }
  set_nonblocking(fd);
  return fd;
}

int tcp_connect(const char* host, int port, std::string& err) {
  sockaddr_in a;
  if (!resolve(host, port, a, err)) return -1;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    err = std::string("socket: ") + std::strerror(errno);
    return -1;
  }
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0) {
    err = std::string(host) + ":" + std::to_string(port) + ": " + std::strerror(errno);
    ::close(fd);
    return -1;
  }
  set_nonblocking(fd);
  return fd;
}

}  // namespace edgefuse::hal
