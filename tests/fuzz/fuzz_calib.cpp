// Fuzz target for the calibration store's slot images (`calib load`, edgefused's start-up): a slot
// file can be torn by a power cut or corrupted on the card. Invariants:
//   - no crash or sanitizer report; a refusal says why (a SlotStatus other than kValid);
//   - a refused slot leaves the caller's CalibrationData as it was;
//   - an accepted slot re-encodes to an image that decodes to the same data and sequence number.
#include <cstdint>
#include <cstring>

#include "edgefuse/runtime/calibration.hpp"
#include "fuzz_check.hpp"

using namespace edgefuse::runtime;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static CalibrationData d, again, untouched;
  static uint8_t image[1 << 16], image2[1 << 16];
  d = CalibrationData();
  d.pair_count = 1;  // a sentinel the decoder must not change on a refusal
  untouched = d;
  uint32_t seq = 77;
  const SlotStatus st = calib_decode(data, size, d, seq);
  if (st != SlotStatus::kValid) {
    // Compared through their images: the structs' padding is not part of the data.
    const size_t a = calib_encode(d, 0, image, sizeof image), b = calib_encode(untouched, 0, image2, sizeof image2);
    FUZZ_CHECK(a == b && !std::memcmp(image, image2, a) && seq == 77, "a refused slot (%s) changed the caller's data",
               to_string(st));
    return 0;
  }
  FUZZ_CHECK(d.pair_count >= 0 && d.pair_count <= kCalibPairsMax && d.intrinsic_count >= 0 &&
                 d.intrinsic_count <= kCalibIntrinsicsMax,
             "an accepted slot holds %d pairs and %d intrinsics", d.pair_count, d.intrinsic_count);
  FUZZ_CHECK(calib_image_size() <= sizeof image, "slot images grew beyond the target's buffer");
  const size_t n = calib_encode(d, seq, image, sizeof image);
  FUZZ_CHECK(n == calib_image_size(), "an accepted slot re-encodes to %zu bytes", n);
  uint32_t seq2 = 0;
  FUZZ_CHECK(calib_decode(image, n, again, seq2) == SlotStatus::kValid && seq2 == seq,
             "a re-encoded slot does not decode");
  FUZZ_CHECK(calib_encode(again, seq2, image2, sizeof image2) == n && !std::memcmp(image, image2, n),
             "decode(encode(x)) is not stable");
  return 0;
}
