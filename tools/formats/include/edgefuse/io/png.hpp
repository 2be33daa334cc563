// PNG images through libpng: 16-bit grey (depth, ToF amplitude) and 8-bit colour.
//
// Readers return false and set `err` to "<path>: <what is wrong>" on any failure (missing file,
// not a PNG, truncated or corrupt data, wrong pixel format); libpng errors become messages.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/core/image.hpp"

namespace edgefuse::io {

//! Reads a 16-bit greyscale PNG into `px` (row-major, w * h values). Any other pixel format
//! (8-bit grey, RGB, palette, grey+alpha) is rejected: depth must never be silently rescaled.
bool read_png_u16(const std::string& path, std::vector<uint16_t>& px, int& w, int& h, std::string& err);

//! Reads an 8-bit or 16-bit RGB, RGBA, grey, grey+alpha or palette PNG as 8-bit RGB (alpha dropped,
//! grey replicated, 16-bit scaled to 8).
bool read_png_rgb8(const std::string& path, std::vector<Rgb8>& px, int& w, int& h, std::string& err);

//! Reads only the header: size, bit depth (1..16) and PNG colour type (0 grey, 2 RGB, 3 palette,
//! 4 grey+alpha, 6 RGBA).
bool read_png_info(const std::string& path, int& w, int& h, int& bit_depth, int& colour_type, std::string& err);

//! Writes a 16-bit greyscale PNG (px.size() must be w * h).
bool write_png_u16(const std::string& path, const std::vector<uint16_t>& px, int w, int h, std::string& err);
//! Writes an 8-bit RGB PNG (px.size() must be w * h).
bool write_png_rgb8(const std::string& path, const std::vector<Rgb8>& px, int w, int h, std::string& err);

}  // namespace edgefuse::io
