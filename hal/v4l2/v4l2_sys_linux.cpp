#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "edgefuse/hal/v4l2/v4l2_sys.hpp"

namespace edgefuse::hal {

namespace {

class LinuxV4l2Sys final : public V4l2Sys {
 public:
  int open(const char* path, int flags) override { return ::open(path, flags); }
  int close(int fd) override { return ::close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override { return ::ioctl(fd, request, arg); }
  int poll(pollfd* fds, nfds_t n, int timeout_ms) override { return ::poll(fds, n, timeout_ms); }
  void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override {
    return ::mmap(nullptr, length, prot, flags, fd, offset);
  }
  int munmap(void* addr, std::size_t length) override { return ::munmap(addr, length); }
};

}  // namespace

V4l2Sys& linux_v4l2_sys() {
  static LinuxV4l2Sys sys;
  return sys;
}

}  // namespace edgefuse::hal
