// Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999): removes every 0x00 from a block so
// that 0x00 can delimit frames on a byte stream (serial, TCP). Overhead: at most 1 byte per 254
// bytes plus 1. No OS, no heap.
#pragma once

#include <cstddef>
#include <cstdint>

namespace edgefuse::link {

//! Largest encoding of `n` bytes (without the 0x00 delimiter).
constexpr size_t cobs_max_encoded_size(size_t n) { return n + n / 254 + 1; }

//! Encodes `len` bytes of `in` into `out`.
//! \param in   bytes to encode
//! \param len  their number
//! \param out  destination, must not overlap `in`
//! \param cap  capacity of `out`
//! \return the encoded length (no 0x00 inside), or 0 if `cap` is too small
size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t cap);

//! Decodes a COBS block (without its delimiter). Works in place (out == in).
//! \param in   encoded bytes (must contain no 0x00)
//! \param len  their number
//! \param out  destination, at least `len` bytes; may equal `in`
//! \return the decoded length, or -1 if the block is malformed (a zero byte or a code that runs
//!         past the end)
long cobs_decode(const uint8_t* in, size_t len, uint8_t* out);

}  // namespace edgefuse::link
