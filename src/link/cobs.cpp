#include "edgefuse/link/cobs.hpp"

namespace edgefuse::link {

size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t cap) {
  if (cap < cobs_max_encoded_size(len)) return 0;
  size_t code_at = 0;  // where the current block's code byte goes
  size_t o = 1;
  uint8_t code = 1;
  for (size_t i = 0; i < len; ++i) {
    if (in[i] == 0) {
      out[code_at] = code;
      code_at = o++;
      code = 1;
      continue;
    }
    out[o++] = in[i];
    if (++code == 0xFF) {
      // A full block of 254 non-zero bytes: close it without an implied zero.
      out[code_at] = code;
      code_at = o++;
      code = 1;
    }
  }
  out[code_at] = code;
  return o;
}

long cobs_decode(const uint8_t* in, size_t len, uint8_t* out) {
  size_t i = 0;
  size_t o = 0;
  while (i < len) {
    const uint8_t code = in[i++];
    if (code == 0) return -1;
    if (i + (code - 1u) > len) return -1;
    // Copy forwards: in-place decoding is safe because o never passes i.
    for (uint8_t k = 1; k < code; ++k) {
      if (in[i] == 0) return -1;
      out[o++] = in[i++];
    }
    if (code != 0xFF && i < len) out[o++] = 0;
  }
  return static_cast<long>(o);
}

}  // namespace edgefuse::link
