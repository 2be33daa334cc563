// CRC-32 with the zlib / IEEE 802.3 polynomial (reflected 0xEDB88320, init and final xor
// 0xFFFFFFFF): the checksum every pose-link frame carries. Table-driven, no OS, no heap, so it
// runs on the board as well as in host tools; equal to zlib's crc32() (tested).
#pragma once

#include <cstddef>
#include <cstdint>

namespace edgefuse::link {

//! CRC-32 of `len` bytes at `data`.
//! \param data bytes to check (may be null when len is 0)
//! \param len  number of bytes
//! \param crc  a previous result to continue from (0 to start)
uint32_t crc32(const uint8_t* data, size_t len, uint32_t crc = 0);

}  // namespace edgefuse::link
