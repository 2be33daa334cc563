// Calibration data of a rig (extrinsics per sensor pair, intrinsic overrides, the rig's mounting
// on the flange (hand-eye), the bin pose) and its slot image: a fixed little-endian layout with
// a header (magic, format version, sequence number, payload length) and a CRC-32 over both, so a
// torn, truncated or bit-flipped slot is recognised. Portable: no OS calls, no heap. The files and
// the atomic two-slot writing are in hal/platform/config (calib_file_store.hpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace edgefuse::runtime {

constexpr int kCalibPairsMax = 6;       //!< sensor pairs (3 sensors: 3 pairs, with room)
constexpr int kCalibIntrinsicsMax = 4;  //!< intrinsic overrides
constexpr size_t kSensorNameMax = 15;   //!< sensor names as in rig.toml, e.g. "xtion"

//! A rigid transform as translation (m) and unit quaternion (x y z w): tq[0..6].
struct CalibPose {
  float tq[7] = {0, 0, 0, 0, 0, 0, 1};
};

//! T_from_to: maps points from sensor `to` into sensor `from`.
struct SensorPair {
  char from[kSensorNameMax + 1] = {};
  char to[kSensorNameMax + 1] = {};
  CalibPose T_from_to;
};

struct IntrinsicOverride {
  char sensor[kSensorNameMax + 1] = {};
  float fx = 0, fy = 0, cx = 0, cy = 0;  //!< pixels
};

struct CalibrationData {
  int pair_count = 0;
  SensorPair pairs[kCalibPairsMax];
  int intrinsic_count = 0;
  IntrinsicOverride intrinsics[kCalibIntrinsicsMax];
  CalibPose T_flange_rig;  //!< hand-eye: the rig's mounting on the robot flange
  CalibPose T_world_bin;   //!< the bin in the world (robot base) frame
};

//! Sets (or adds) the transform of a pair.
//! \return false if the table is full or a name is too long
bool calib_set_pair(CalibrationData& d, const char* from, const char* to, const CalibPose& T_from_to);
//! The pair's entry, or nullptr.
const SensorPair* calib_find_pair(const CalibrationData& d, const char* from, const char* to);

constexpr size_t kCalibHeaderBytes = 20;
//! Size of every slot image (the layout is fixed).
size_t calib_image_size();

//! Why a slot was or was not accepted.
enum class SlotStatus { kValid, kMissing, kTruncated, kBadMagic, kBadVersion, kBadCrc, kBadContent };
const char* to_string(SlotStatus s);

//! Writes the slot image.
//! \param d    the data
//! \param seq  sequence number of this save (newest wins on loading)
//! \param out  destination
//! \param cap  its capacity, at least calib_image_size()
//! \return bytes written, or 0 if cap is too small
size_t calib_encode(const CalibrationData& d, uint32_t seq, uint8_t* out, size_t cap);

//! Checks and reads a slot image.
//! \param in   the bytes of a slot file
//! \param len  their number
//! \param d    filled when valid
//! \param seq  its sequence number when valid
SlotStatus calib_decode(const uint8_t* in, size_t len, CalibrationData& d, uint32_t& seq);

//! True if sequence number a is newer than b (wrap-around safe).
inline bool seq_newer(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b) > 0; }

}  // namespace edgefuse::runtime
