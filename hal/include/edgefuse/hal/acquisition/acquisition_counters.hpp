// Counters of one device's acquisition, written by its thread and read by the status command.
// Relaxed atomics: each is an independent tally; a snapshot may mix adjacent instants.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace edgefuse::hal {

//! Why a frame was rejected by the sanity checks.
enum class FrameReject : uint8_t { kNone, kSize, kStamp, kAllInvalid, kDriver, kCount };
const char* to_string(FrameReject r);

//! What the device thread is doing (the runtime pauses tracking unless kStreaming).
enum class DeviceState : uint8_t { kStopped, kOpening, kStreaming, kBackoff, kUnplugged, kEnded };
const char* to_string(DeviceState s);

struct AcquisitionCounters {
  std::atomic<uint32_t> frames{0};            //!< frames received from the device
  std::atomic<uint32_t> published{0};         //!< frames handed to processing
  std::atomic<uint32_t> dropped_overrun{0};   //!< processing held every slot: the frame was overwritten
  std::atomic<uint32_t> dropped_stale{0};     //!< a newer frame arrived before processing took this one
  std::atomic<uint32_t> device_gaps{0};       //!< frames missing in the device's sequence numbers
  std::atomic<uint32_t> rejected[size_t(FrameReject::kCount)] = {};  //!< by reason
  std::atomic<uint32_t> timeouts{0};          //!< next_frame timed out
  std::atomic<uint32_t> stalls{0};            //!< no frame for stall_ms: the device was reopened
  std::atomic<uint32_t> opens{0};             //!< successful start()s
  std::atomic<uint32_t> open_failures{0};     //!< failed start()s (followed by back-off)
  std::atomic<uint32_t> disconnects{0};       //!< the device vanished (kNoDevice)
  std::atomic<uint32_t> reconnects{0};        //!< it came back (DeviceMonitor or a successful reopen)
  std::atomic<uint32_t> io_errors{0};         //!< other driver errors
  std::atomic<uint64_t> last_stamp_us{0};     //!< stamp of the last published frame
  std::atomic<uint8_t> state{uint8_t(DeviceState::kStopped)};

  uint32_t rejected_total() const;
  DeviceState device_state() const { return DeviceState(state.load()); }
};

//! One line for the status command: "state=streaming frames=.. published=.. ...".
//! \param c the counters  \param out buffer  \param size its size (output is truncated to fit)
//! \return characters that the full line needs (as snprintf)
int format_counters(const AcquisitionCounters& c, char* out, std::size_t size);

}  // namespace edgefuse::hal
