#include "edgefuse/hal/platform/config/calib_file_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

namespace edgefuse::hal {

using runtime::CalibrationData;
using runtime::SlotStatus;

const char* to_string(SaveStep s) {
  switch (s) {
    case SaveStep::kOpenTemp: return "open temporary file";
    case SaveStep::kWriteFirstHalf: return "write (first half)";
    case SaveStep::kWriteSecondHalf: return "write (second half)";
    case SaveStep::kFsyncFile: return "fsync file";
    case SaveStep::kClose: return "close";
    case SaveStep::kRename: return "rename";
    case SaveStep::kFsyncDir: return "fsync folder";
  }
  return "?";
}

namespace {

bool read_file(const std::string& path, std::vector<uint8_t>& out) {
  out.clear();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    out.insert(out.end(), buf, buf + n);
    if (out.size() > (1u << 20)) break;  // not a slot; do not read a huge file
  }
  ::close(fd);
  return true;
}

bool write_all(int fd, const uint8_t* p, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= size_t(w);
  }
  return true;
}

}  // namespace

std::string CalibFileStore::slot_path(int slot) const { return dir_ + (slot == 0 ? "/calib_a.bin" : "/calib_b.bin"); }

bool CalibFileStore::load(CalibrationData& d, CalibLoadReport& rep) const {
  rep = CalibLoadReport{};
  CalibrationData found[2];
  uint32_t seq[2] = {0, 0};
  std::vector<uint8_t> bytes;
  for (int s = 0; s < 2; ++s) {
    if (!read_file(slot_path(s), bytes)) {
      rep.status[s] = SlotStatus::kMissing;
      continue;
    }
    rep.status[s] = bytes.empty() ? SlotStatus::kTruncated
                                  : runtime::calib_decode(bytes.data(), bytes.size(), found[s], seq[s]);
  }
  const bool ok0 = rep.status[0] == SlotStatus::kValid;
  const bool ok1 = rep.status[1] == SlotStatus::kValid;
  if (ok0 || ok1) rep.slot = (ok0 && (!ok1 || !runtime::seq_newer(seq[1], seq[0]))) ? 0 : 1;
  std::string msg;
  if (rep.slot >= 0) {
    d = found[rep.slot];
    rep.seq = seq[rep.slot];
    msg = "calibration: loaded " + slot_path(rep.slot) + " (seq " + std::to_string(rep.seq) + ")";
  } else {
    msg = "calibration: no valid slot in " + dir_ + ", using defaults";
  }
  for (int s = 0; s < 2; ++s)
    if (rep.status[s] != SlotStatus::kValid && rep.status[s] != SlotStatus::kMissing)
      msg += "; " + slot_path(s) + " is " + runtime::to_string(rep.status[s]) + ", ignored";
  rep.message = msg;
  return rep.slot >= 0;
}

bool CalibFileStore::save(const CalibrationData& d, std::string& err) {
  CalibrationData current;
  CalibLoadReport rep;
  const bool have = load(current, rep);
  const int target = have ? 1 - rep.slot : 0;
  const uint32_t seq = have ? rep.seq + 1 : 1;
  std::vector<uint8_t> image(runtime::calib_image_size());
  runtime::calib_encode(d, seq, image.data(), image.size());

  ::mkdir(dir_.c_str(), 0755);  // may exist
  const std::string path = slot_path(target);
  const std::string tmp = path + ".tmp";
  int fd = -1;
  auto fail = [&](SaveStep s) {
    err = path + ": " + to_string(s) + " failed" + (errno ? std::string(": ") + std::strerror(errno) : "");
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    return false;
  };
  auto step = [&](SaveStep s) {
    errno = 0;
    return hook_ == nullptr || hook_(s, hook_ctx_);
  };
  const size_t half = image.size() / 2;
  if (!step(SaveStep::kOpenTemp) ||
      (fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)) < 0)
    return fail(SaveStep::kOpenTemp);
  if (!step(SaveStep::kWriteFirstHalf) || !write_all(fd, image.data(), half)) return fail(SaveStep::kWriteFirstHalf);
  if (!step(SaveStep::kWriteSecondHalf) || !write_all(fd, image.data() + half, image.size() - half))
    return fail(SaveStep::kWriteSecondHalf);
  if (!step(SaveStep::kFsyncFile) || ::fsync(fd) != 0) return fail(SaveStep::kFsyncFile);
  const int closing = fd;
  fd = -1;
  if (!step(SaveStep::kClose)) {
    ::close(closing);
    return fail(SaveStep::kClose);
  }
  if (::close(closing) != 0) return fail(SaveStep::kClose);
  if (!step(SaveStep::kRename) || ::rename(tmp.c_str(), path.c_str()) != 0) return fail(SaveStep::kRename);
  // The rename is durable only once the folder is synced; the data itself is already.
  const int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  const bool synced = step(SaveStep::kFsyncDir) && dfd >= 0 && ::fsync(dfd) == 0;
  if (dfd >= 0) ::close(dfd);
  if (!synced) {
    err = dir_ + ": fsync of the folder failed (the new slot may not survive a power cut)";
    return false;
  }
  return true;
}

}  // namespace edgefuse::hal
