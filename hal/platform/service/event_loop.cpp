#include "edgefuse/hal/platform/service/event_loop.hpp"

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>

#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/hal/platform/systemd/sd_notify.hpp"

namespace edgefuse::hal {
namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int sig) { g_stop = sig; }
char g_buf[4096];

void install_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

void read_inputs(const ServiceSources& s, ServiceHandler& handler) {
  if (s.console_fd >= 0) {
    const ssize_t r = ::read(s.console_fd, g_buf, sizeof(g_buf));
    if (r > 0) handler.console_input(g_buf, size_t(r));
  }
  if (s.link_fd >= 0) {
    ssize_t r;
    while ((r = ::read(s.link_fd, g_buf, sizeof(g_buf))) > 0) {
      if (s.console_on_link)
        handler.console_input(g_buf, size_t(r));
      else
        handler.link_input(reinterpret_cast<const uint8_t*>(g_buf), size_t(r));
    }
  }
}

}  // namespace

int serve_until_signal(const ServiceSources& s, ServiceHandler& handler) {
  install_signals();
  Clock& clock = monotonic_clock();
  const uint64_t watchdog_us = sd_watchdog_usec();
  uint64_t next_watchdog_us = 0;
  sd_notify_send("READY=1");
  std::printf("ready\n");
  std::fflush(stdout);
  pollfd fds[4 + 2 * TcpServer::kMaxClients];
  TcpServer* servers[2] = {s.tcp, s.text};
  while (!g_stop) {
    int n = 0;
    if (s.console_fd >= 0) fds[n++] = {s.console_fd, POLLIN, 0};
    if (s.link_fd >= 0) fds[n++] = {s.link_fd, POLLIN, 0};
    for (TcpServer* server : servers) {
      if (server == nullptr) continue;
      if (server->listen_fd() >= 0) fds[n++] = {server->listen_fd(), POLLIN, 0};
      for (int i = 0; i < TcpServer::kMaxClients; ++i)
        if (server->client_fd(i) >= 0) fds[n++] = {server->client_fd(i), POLLIN, 0};
    }
    ::poll(fds, nfds_t(n), 10);
    read_inputs(s, handler);
    for (TcpServer* server : servers)
      if (server != nullptr) server->service();
    const uint64_t t = clock.now_us();
    handler.tick(t);
    if (watchdog_us > 0 && t >= next_watchdog_us) {
      sd_notify_send("WATCHDOG=1");
      next_watchdog_us = t + watchdog_us / 2;
    }
  }
  sd_notify_send("STOPPING=1");
  return int(g_stop);
}

}  // namespace edgefuse::hal
