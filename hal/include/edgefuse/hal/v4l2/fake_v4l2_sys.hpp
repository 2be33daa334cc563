// A fake V4L2 driver behind V4l2Sys for host tests: a configurable format list and frame size,
// mmap buffers it owns, the QBUF/DQBUF queues, and injectable faults (EINTR from poll, driver
// error flags, truncated frames, a device that vanishes and comes back). Frames are pushed by the
// test; poll never blocks (no frame = timeout at once). Test code: it allocates.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "edgefuse/hal/v4l2/v4l2_sys.hpp"

namespace edgefuse::hal {

class FakeV4l2Sys final : public V4l2Sys {
 public:
  // --- driver description (set before open) -----------------------------------------------
  std::vector<uint32_t> formats;  //!< fourccs ENUM_FMT lists
  uint32_t width = 320, height = 240;  //!< the only size: S_FMT adjusts any request to it
  uint32_t padding_bytes = 16;    //!< bytesperline = width * 2 + padding
  uint32_t max_buffers = 3;       //!< REQBUFS grants at most this many
  bool present = true;            //!< false: open fails with ENOENT

  // --- faults ------------------------------------------------------------------------------
  int poll_eintr = 0;             //!< the next n polls fail with EINTR
  //! The device vanishes: every call on the open descriptor fails with ENODEV, poll reports POLLERR.
  void vanish() { present = false; gone_ = true; }

  // --- frames ------------------------------------------------------------------------------
  //! The driver fills the oldest queued buffer; false (a driver-side drop) when none is queued.
  //! \param depth width*height values  \param stamp_us buffer time stamp  \param flags extra V4L2_BUF_FLAG_*
  //! \param bytesused_override 0: the full image
  bool push_frame(const uint16_t* depth, uint64_t stamp_us, uint32_t flags = 0, uint32_t bytesused_override = 0);

  // --- what the backend did ----------------------------------------------------------------
  uint32_t negotiated_format = 0;
  int streamon_calls = 0, streamoff_calls = 0, qbuf_calls = 0, dqbuf_calls = 0, munmaps = 0, closes = 0, opens = 0;
  int driver_drops = 0;
  std::size_t queued() const { return queued_.size(); }
  std::size_t done() const { return done_.size(); }
  bool is_open() const { return open_; }

  int open(const char* path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  int poll(pollfd* fds, nfds_t n, int timeout_ms) override;
  void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override;
  int munmap(void* addr, std::size_t length) override;

 private:
  struct Buffer {
    std::vector<uint8_t> data;
    uint32_t bytesused = 0, flags = 0, sequence = 0;
    uint64_t stamp_us = 0;
  };
  static constexpr int kFd = 42;
  // ioctl's requests; arg is the request's struct.
  int enum_format(void* arg) const;
  int set_format(void* arg);
  int request_buffers(void* arg);
  int query_buffer(void* arg) const;
  int queue_buffer(void* arg);
  int dequeue_buffer(void* arg);
  bool open_ = false, gone_ = false, streaming_ = false;
  std::vector<Buffer> buffers_;
  std::deque<uint32_t> queued_, done_;
  uint32_t sequence_ = 0;
};

}  // namespace edgefuse::hal
