#include "oni_test_recording.hpp"

#include <OpenNI.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sys/wait.h>
#include <unistd.h>
#include <iterator>
#include <thread>
#include <vector>

namespace edgefuse_test {

namespace {

// .oni records (OpenNI's DataRecords.h): a 28-byte header {"NIR\0", type, node id, size of header
// + fields, payload size, undo position (u64)}, then the fields.
constexpr std::size_t kFileHeader = 24;
constexpr std::size_t kRecordHeader = 28;
constexpr uint32_t kIntProperty = 3;
constexpr uint32_t kGeneralProperty = 6;

uint32_t get_u32(const std::vector<char>& d, std::size_t at) {
  uint32_t v;
  std::memcpy(&v, d.data() + at, 4);
  return v;
}

void put_u32(std::vector<char>& out, uint32_t v) {
  const char* p = reinterpret_cast<const char*>(&v);
  out.insert(out.end(), p, p + 4);
}

// The property name of a property record at `at` ("" for other records).
std::string property_name(const std::vector<char>& d, std::size_t at) {
  const uint32_t type = get_u32(d, at + 4);
  if (type != kIntProperty && type != kGeneralProperty) return std::string();
  const uint32_t len = get_u32(d, at + kRecordHeader);
  if (len == 0 || at + kRecordHeader + 4 + len > d.size()) return std::string();
  return std::string(d.data() + at + kRecordHeader + 4, len - 1);
}

// A general-property record of exactly `total` bytes (header + fields; no payload).
bool general_property(uint32_t node, const char* name, const std::vector<char>& value, std::size_t total,
                      std::vector<char>& out) {
  out.clear();
  const char magic[4] = {'N', 'I', 'R', 0};
  out.insert(out.end(), magic, magic + 4);
  put_u32(out, kGeneralProperty);
  put_u32(out, node);
  put_u32(out, uint32_t(total));
  put_u32(out, 0);  // payload
  out.insert(out.end(), 8, 0);  // undo position: none
  const uint32_t len = uint32_t(std::strlen(name) + 1);
  put_u32(out, len);
  out.insert(out.end(), name, name + len);
  put_u32(out, uint32_t(value.size()));
  out.insert(out.end(), value.begin(), value.end());
  return out.size() == total;
}

}  // namespace

std::string make_temp_dir() {
  const char* tmp = std::getenv("TMPDIR");
  std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/edgefuse_oni_XXXXXX";
  std::vector<char> buf(templ.begin(), templ.end());
  buf.push_back(0);
  return mkdtemp(buf.data()) ? std::string(buf.data()) : std::string();
}

namespace {

// The recording itself, in a child process (see record_dummy_oni).
std::string record_in_this_process(const std::string& path, int frames) {
  using namespace openni;
  if (OpenNI::initialize() != STATUS_OK) return std::string("OpenNI initialize: ") + OpenNI::getExtendedError();
  std::string err;
  {
    Device device;
    VideoStream depth;
    Recorder rec;
    if (device.open("Dummy") != STATUS_OK) err = "open Dummy";
    if (err.empty() && depth.create(device, SENSOR_DEPTH) != STATUS_OK) err = "create depth";
    if (err.empty() && rec.create(path.c_str()) != STATUS_OK) err = "create recorder " + path;
    if (err.empty() && rec.attach(depth, false) != STATUS_OK) err = "attach recorder";
    if (err.empty() && depth.start() != STATUS_OK) err = "start depth";
    if (err.empty() && rec.start() != STATUS_OK) err = "start recorder";
    VideoFrameRef f;
    for (int i = 0; err.empty() && i < frames; ++i) {
      VideoStream* s[] = {&depth};
      int ready = -1;
      if (OpenNI::waitForAnyStream(s, 1, &ready, 2000) != STATUS_OK || depth.readFrame(&f) != STATUS_OK)
        err = "read Dummy frame";
    }
    f.release();
    if (rec.isValid()) {
      rec.stop();
      rec.destroy();  // writes the seek table and the end record
    }
    if (depth.isValid()) {
      depth.stop();
      // The Dummy's frame thread is not joined by stop() (see openni2_depth_camera.cpp).
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      depth.destroy();
    }
    if (device.isValid()) device.close();
  }
  if (!err.empty()) err += std::string(": ") + OpenNI::getExtendedError();
  OpenNI::shutdown();
  return err;
}

}  // namespace

std::string record_dummy_oni(const std::string& path, int frames, int& recorded) {
  recorded = 0;
  // OpenNI2 2.2 crashes in a later OpenNI::initialize() of a process that used a Recorder (after
  // its shutdown), so the recording runs in a child process that exits afterwards.
  int fds[2];
  if (pipe(fds) != 0) return "pipe failed";
  const pid_t pid = fork();
  if (pid < 0) return "fork failed";
  if (pid == 0) {
    close(fds[0]);
    const std::string e = record_in_this_process(path, frames);
    if (!e.empty() && write(fds[1], e.data(), e.size()) < 0) _exit(2);
    _exit(e.empty() ? 0 : 1);
  }
  close(fds[1]);
  std::string err;
  char buf[256];
  ssize_t n;
  while ((n = read(fds[0], buf, sizeof(buf))) > 0) err.append(buf, std::size_t(n));  // until the child exits
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return "recording child failed" + (err.empty() ? std::string() : ": " + err);
  // Frames in the recording: the node-added record's frame count (after name, type, codec).
  std::ifstream in(path, std::ios::binary);
  std::vector<char> d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (d.size() < kFileHeader + kRecordHeader + 8) return "recording too short: " + path;
  const std::size_t fields = kFileHeader + kRecordHeader;
  const uint32_t name_len = get_u32(d, fields);
  recorded = int(get_u32(d, fields + 4 + name_len + 4 + 4));
  return std::string();
}

std::string add_cropping_record(const std::string& path) {
  std::vector<char> d;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) return "cannot read " + path;
    d.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // Find "xnSupportedMapOutputModesCount" followed by "xnSupportedMapOutputModes": both are
  // ignored by the player, and together big enough for the cropping record plus a filler.
  std::size_t at = kFileHeader;
  while (at + kRecordHeader <= d.size() && std::memcmp(d.data() + at, "NIR", 4) == 0) {
    const std::size_t size = get_u32(d, at + 12) + std::size_t(get_u32(d, at + 16));
    if (property_name(d, at) == "xnSupportedMapOutputModesCount" && at + size + kRecordHeader <= d.size() &&
        property_name(d, at + size) == "xnSupportedMapOutputModes") {
      const std::size_t next = get_u32(d, at + size + 12) + std::size_t(get_u32(d, at + size + 16));
      const std::size_t total = size + next;
      const uint32_t node = get_u32(d, at + 8);
      // XnCropping: XnBool enabled (4 bytes), x/y offset, x/y size (uint16 each): all zero = off.
      std::vector<char> crop_rec, fill_rec;
      const std::size_t crop_total = kRecordHeader + 4 + 11 + 4 + 12;
      const std::size_t fill_fixed = kRecordHeader + 4 + 12 + 4;  // "edgefusePad" + NUL
      if (total < crop_total + fill_fixed) return "records too small to patch in " + path;
      if (!general_property(node, "xnCropping", std::vector<char>(12, 0), crop_total, crop_rec) ||
          !general_property(node, "edgefusePad", std::vector<char>(total - crop_total - fill_fixed, 0),
                            total - crop_total, fill_rec))
        return "building the cropping record failed";
      std::memcpy(d.data() + at, crop_rec.data(), crop_rec.size());
      std::memcpy(d.data() + at + crop_rec.size(), fill_rec.data(), fill_rec.size());
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out.write(d.data(), std::streamsize(d.size()));
      return out ? std::string() : "cannot write " + path;
    }
    at += size;
  }
  return "no supported-modes records to replace in " + path;
}

}  // namespace edgefuse_test
