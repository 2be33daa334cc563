#include "edgefuse/hal/v4l2/fake_v4l2_sys.hpp"

#include <linux/videodev2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace edgefuse::hal {

int FakeV4l2Sys::open(const char*, int) {
  if (!present) {
    errno = ENOENT;
    return -1;
  }
  gone_ = false;
  open_ = true;
  ++opens;
  return kFd;
}

int FakeV4l2Sys::close(int fd) {
  if (fd != kFd || !open_) {
    errno = EBADF;
    return -1;
  }
  open_ = false;
  streaming_ = false;
  ++closes;
  return 0;
}

bool FakeV4l2Sys::push_frame(const uint16_t* depth, uint64_t stamp_us, uint32_t flags, uint32_t bytesused_override) {
  if (!streaming_ || queued_.empty()) {
    ++driver_drops;
    ++sequence_;
    return false;
  }
  const uint32_t idx = queued_.front();
  queued_.pop_front();
  Buffer& b = buffers_[idx];
  const uint32_t bpl = width * 2 + padding_bytes;
  for (uint32_t v = 0; v < height; ++v) {
    std::memcpy(b.data.data() + std::size_t(v) * bpl, depth + std::size_t(v) * width, width * 2u);
    std::memset(b.data.data() + std::size_t(v) * bpl + width * 2u, 0xAB, padding_bytes);  // must not be read
  }
  b.bytesused = bytesused_override ? bytesused_override : bpl * height;
  b.flags = flags;
  b.stamp_us = stamp_us;
  b.sequence = sequence_++;
  done_.push_back(idx);
  return true;
}

int FakeV4l2Sys::poll(pollfd* fds, nfds_t n, int) {
  if (n != 1 || fds[0].fd != kFd) {
    errno = EINVAL;
    return -1;
  }
  if (poll_eintr > 0) {
    --poll_eintr;
    errno = EINTR;
    return -1;
  }
  fds[0].revents = 0;
  if (gone_) {
    fds[0].revents = POLLERR;
    return 1;
  }
  if (!done_.empty()) {
    fds[0].revents = POLLIN;
    return 1;
  }
  return 0;
}

void* FakeV4l2Sys::mmap(std::size_t length, int, int, int fd, off_t offset) {
  const std::size_t idx = std::size_t(offset) / 0x100000u;
  if (fd != kFd || idx >= buffers_.size() || length != buffers_[idx].data.size()) {
    errno = EINVAL;
    return MAP_FAILED;
  }
  return buffers_[idx].data.data();
}

int FakeV4l2Sys::munmap(void*, std::size_t) {
  ++munmaps;
  return 0;
}

namespace {

int query_capabilities(void* arg) {
  auto* cap = static_cast<v4l2_capability*>(arg);
  std::memset(cap, 0, sizeof(*cap));
  std::strcpy(reinterpret_cast<char*>(cap->driver), "fake");
  cap->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
  cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
  return 0;
}

}  // namespace

int FakeV4l2Sys::enum_format(void* arg) const {
  auto* d = static_cast<v4l2_fmtdesc*>(arg);
  if (d->index >= formats.size()) {
    errno = EINVAL;
    return -1;
  }
  d->pixelformat = formats[d->index];
  return 0;
}

int FakeV4l2Sys::set_format(void* arg) {
  const uint32_t bpl = width * 2 + padding_bytes;
  auto* f = static_cast<v4l2_format*>(arg);
  // As drivers do: adjust to what the hardware has instead of failing.
  f->fmt.pix.width = width;
  f->fmt.pix.height = height;
  if (std::find(formats.begin(), formats.end(), f->fmt.pix.pixelformat) == formats.end())
    f->fmt.pix.pixelformat = formats.empty() ? 0 : formats[0];
  f->fmt.pix.bytesperline = bpl;
  f->fmt.pix.sizeimage = bpl * height;
  negotiated_format = f->fmt.pix.pixelformat;
  return 0;
}

int FakeV4l2Sys::request_buffers(void* arg) {
  const uint32_t bpl = width * 2 + padding_bytes;
  auto* r = static_cast<v4l2_requestbuffers*>(arg);
  if (streaming_) {
    errno = EBUSY;
    return -1;
  }
  r->count = std::min(r->count, max_buffers);
  buffers_.assign(r->count, Buffer{});
  for (Buffer& b : buffers_) b.data.assign(std::size_t(bpl) * height, 0);
  queued_.clear();
  done_.clear();
  return 0;
}

int FakeV4l2Sys::query_buffer(void* arg) const {
  auto* b = static_cast<v4l2_buffer*>(arg);
  if (b->index >= buffers_.size()) {
    errno = EINVAL;
    return -1;
  }
  b->length = uint32_t(buffers_[b->index].data.size());
  b->m.offset = b->index * 0x100000u;
  return 0;
}

int FakeV4l2Sys::queue_buffer(void* arg) {
  auto* b = static_cast<v4l2_buffer*>(arg);
  if (b->index >= buffers_.size() || std::find(queued_.begin(), queued_.end(), b->index) != queued_.end()) {
    errno = EINVAL;
    return -1;
  }
  ++qbuf_calls;
  queued_.push_back(b->index);
  return 0;
}

int FakeV4l2Sys::dequeue_buffer(void* arg) {
  auto* b = static_cast<v4l2_buffer*>(arg);
  if (done_.empty()) {
    errno = EAGAIN;
    return -1;
  }
  ++dqbuf_calls;
  const uint32_t idx = done_.front();
  done_.pop_front();
  const Buffer& s = buffers_[idx];
  b->index = idx;
  b->bytesused = s.bytesused;
  b->flags = s.flags | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  b->sequence = s.sequence;
  b->timestamp.tv_sec = time_t(s.stamp_us / 1000000u);
  b->timestamp.tv_usec = suseconds_t(s.stamp_us % 1000000u);
  return 0;
}

int FakeV4l2Sys::ioctl(int fd, unsigned long request, void* arg) {
  if (fd != kFd || !open_) {
    errno = EBADF;
    return -1;
  }
  if (gone_) {
    errno = ENODEV;
    return -1;
  }
  switch (request) {
    case VIDIOC_QUERYCAP: return query_capabilities(arg);
    case VIDIOC_ENUM_FMT: return enum_format(arg);
    case VIDIOC_S_FMT: return set_format(arg);
    case VIDIOC_S_PARM: return 0;
    case VIDIOC_REQBUFS: return request_buffers(arg);
    case VIDIOC_QUERYBUF: return query_buffer(arg);
    case VIDIOC_QBUF: return queue_buffer(arg);
    case VIDIOC_DQBUF: return dequeue_buffer(arg);
    case VIDIOC_STREAMON: streaming_ = true; ++streamon_calls; return 0;
    case VIDIOC_STREAMOFF:
      streaming_ = false;
      ++streamoff_calls;
      queued_.clear();
      done_.clear();
      return 0;
    default: errno = ENOTTY; return -1;
  }
}

}  // namespace edgefuse::hal
