// The kernel boundary of the V4L2 backend: open/close/ioctl/poll/mmap/munmap behind one
// interface, so a fake driver (fake_v4l2_sys.hpp) can exercise format negotiation, buffer cycling,
// timeouts, EINTR and a vanished device (ENODEV) on any host. Calls return what the system calls
// return (-1 with errno set on failure).
#pragma once

#include <poll.h>
#include <sys/types.h>

#include <cstddef>

namespace edgefuse::hal {

class V4l2Sys {
 public:
  virtual ~V4l2Sys() = default;
  //! \param path device node  \param flags open(2) flags
  virtual int open(const char* path, int flags) = 0;
  //! \param fd descriptor
  virtual int close(int fd) = 0;
  //! \param fd descriptor  \param request VIDIOC_*  \param arg the request's structure
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  //! \param fds descriptors  \param n count  \param timeout_ms longest wait
  virtual int poll(pollfd* fds, nfds_t n, int timeout_ms) = 0;
  //! \param length bytes  \param prot PROT_*  \param flags MAP_*  \param fd descriptor  \param offset from QUERYBUF
  virtual void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) = 0;
  //! \param addr mapping  \param length bytes
  virtual int munmap(void* addr, std::size_t length) = 0;
};

//! The real system calls.
V4l2Sys& linux_v4l2_sys();

}  // namespace edgefuse::hal
