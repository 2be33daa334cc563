// Fuzz target for the serial console on the real runtime (edgefused's Runtime with host-sim's
// simulated pipeline): any byte stream a terminal, a cable fault or a confused script can send.
// The input is chunks of console bytes; a 0xFF byte ends a chunk and the byte after it advances
// the clock by that many 20 ms ticks (so scans, localisations and heartbeats happen in between).
// Invariants:
//   - no crash or sanitizer report, whatever the bytes;
//   - the console writes printable lines only, each ending in CR LF, at most 255 characters;
//   - a chunk that ends a non-empty line is answered, and the answer's last line is "OK" or
//     "ERR <code> <message>" with a documented code (1-9);
//   - after every chunk each parameter holds a value its own set() accepts again, and the runtime's
//     state is one of its four;
//   - every link frame the runtime sends decodes (CRC, COBS and protobuf);
//   - the calibration slot the runtime saves decodes again (in-memory store through the codec).
#include <cstdint>
#include <cstring>
#include <string>

#include "../firmware/exact_pose_pipeline.hpp"
#include "edgefuse/link/frame.hpp"
#include "edgefuse/link/messages.hpp"
#include "edgefuse/link/publisher.hpp"
#include "edgefuse/runtime/console.hpp"
#include "edgefuse/runtime/runtime.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace edgefuse;
using namespace edgefuse::runtime;

class CheckedWriter : public ConsoleWriter {
 public:
  void write(const char* s, size_t n) override {
    for (size_t i = 0; i < n; ++i) {
      const unsigned char c = static_cast<unsigned char>(s[i]);
      if (c == '\n') {
        FUZZ_CHECK(line_len_ > 0 && line_[line_len_ - 1] == '\r', "a reply line does not end in CR LF");
        line_[line_len_ - 1] = '\0';
        std::memcpy(last_, line_, line_len_);
        line_len_ = 0;
        ++lines_;
        continue;
      }
      FUZZ_CHECK(c == '\r' || (c >= 0x20 && c <= 0x7E), "the console wrote the byte 0x%02x", c);
      FUZZ_CHECK(line_len_ < 256, "a reply line longer than 255 characters");
      line_[line_len_++] = char(c);
    }
  }
  unsigned lines() const { return lines_; }
  size_t pending() const { return line_len_; }
  const char* last() const { return last_; }

 private:
  char line_[258] = {};
  char last_[258] = {};
  size_t line_len_ = 0;
  unsigned lines_ = 0;
};

class MemoryStorage : public CalibrationStorage {
 public:
  bool save(const CalibrationData& d, char* msg, size_t cap) override {
    len_ = calib_encode(d, ++seq_, slot_, sizeof slot_);
    FUZZ_CHECK(len_ > 0, "the calibration does not encode");
    CalibrationData back;
    uint32_t seq = 0;
    FUZZ_CHECK(calib_decode(slot_, len_, back, seq) == SlotStatus::kValid && seq == seq_,
               "a saved calibration does not decode");
    std::snprintf(msg, cap, "saved to memory");
    return true;
  }
  bool load(CalibrationData& d, char* msg, size_t cap) override {
    uint32_t seq = 0;
    if (len_ == 0 || calib_decode(slot_, len_, d, seq) != SlotStatus::kValid) {
      std::snprintf(msg, cap, "no calibration saved");
      return false;
    }
    return true;
  }

 private:
  uint8_t slot_[1 << 16] = {};
  size_t len_ = 0;
  uint32_t seq_ = 0;
};

class CheckedLink : public link::FrameSink {
 public:
  void send(const uint8_t* frame, size_t len) override {
    FUZZ_CHECK(len <= sizeof copy_, "a %zu-byte frame", len);
    std::memcpy(copy_, frame, len);
    size_t n = 0;
    FUZZ_CHECK(link::frame_decode_inplace(copy_, len, n), "the runtime sent a frame that does not decode");
    FUZZ_CHECK(link::decode_message(copy_, n, msg_), "the runtime sent a message that does not decode");
  }

 private:
  uint8_t copy_[link::kMaxFrame];
  link::Message msg_;
};

bool line_is_reply_end(const char* s) {
  if (!std::strcmp(s, "OK")) return true;
  if (std::strncmp(s, "ERR ", 4) != 0) return false;
  const char* p = s + 4;
  if (*p < '1' || *p > '9' || p[1] != ' ') return false;
  return p[2] != '\0';  // a message follows the code
}

void check_params(const ParamStore& params) {
  char text[ParamStore::kTextCap], err[200];
  static ParamStore again;
  for (int id = 0; id < kParamCount; ++id) {
    params.format(id, text, sizeof text);
    FUZZ_CHECK(again.set(id, text, err, sizeof err), "%s holds %s, which set() refuses: %s", kParamDefs[id].key, text,
               err);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Fresh objects for every input: a finding must not depend on the inputs run before it.
  static ParamStore params;
  params = ParamStore();
  edgefuse_test::ExactPosePipeline pipeline;
  MemoryStorage storage;
  CheckedLink link;
  link::LinkPublisher publisher(link);
  CheckedWriter out;
  Runtime runtime(pipeline, params, storage, publisher);
  Console console(runtime, params, out, "edgefuse fuzz");
  uint64_t now_us = 1000000;
  runtime.tick(now_us);

  size_t i = 0;
  while (i < size) {
    size_t end = i;
    while (end < size && data[end] != 0xFF) ++end;
    const unsigned before = out.lines();
    console.feed(reinterpret_cast<const char*>(data + i), end - i);
    // A line the chunk completed is answered at once (commands never wait for the pipeline); a
    // chunk may also end several lines, or none, so only the last line written is checked.
    FUZZ_CHECK(out.pending() == 0, "the console left a reply line unfinished");
    if (out.lines() != before)
      FUZZ_CHECK(line_is_reply_end(out.last()), "a reply ends in '%s', not OK or ERR <code> <message>", out.last());
    check_params(params);
    const RuntimeState st = runtime.state();
    FUZZ_CHECK(st == RuntimeState::kIdle || st == RuntimeState::kMapping || st == RuntimeState::kLocalize ||
                   st == RuntimeState::kReport,
               "runtime state %d", int(st));
    if (end + 1 < size) {
      for (int t = 0; t < data[end + 1]; ++t) runtime.tick(now_us += 20000);
      i = end + 2;
    } else {
      i = end + 1;
    }
  }
  return 0;
}
