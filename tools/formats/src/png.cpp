// libpng wrappers. libpng reports errors by longjmp; to keep that well defined in C++ the frames
// that call setjmp (read_header, read_rows, write_image) hold only trivially destructible locals,
// and every buffer is sized by the caller before libpng writes into it.
#include "edgefuse/io/png.hpp"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <new>

#include "file_util.hpp"

namespace edgefuse::io {
namespace {

using detail::format;

struct ErrorState {
  char msg[256];
};

struct MemoryReader {
  const unsigned char* data;
  std::size_t size;
  std::size_t pos;
  bool truncated;
};

void on_error(png_structp png, png_const_charp msg) {
  ErrorState* st = static_cast<ErrorState*>(png_get_error_ptr(png));
  std::snprintf(st->msg, sizeof st->msg, "%s", msg ? msg : "unknown error");
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // benign (e.g. ancillary chunk CRC): ignored

void on_read(png_structp png, png_bytep out, png_size_t n) {
  MemoryReader* r = static_cast<MemoryReader*>(png_get_io_ptr(png));
  if (r->size - r->pos < n) {
    r->truncated = true;
    png_error(png, "unexpected end of file");
  }
  std::memcpy(out, r->data + r->pos, n);
  r->pos += n;
}

enum class Mode { kInfo, kU16, kRgb8 };

struct HeaderInfo {
  png_uint_32 width, height;
  int bit_depth, colour_type;  // as stored in the file
  int out_bit_depth, out_channels;
  png_size_t rowbytes;  // after the transforms
};

// Returns 1 ok, 0 libpng error (message in the error state).
int read_header(png_structp png, png_infop info, Mode mode, HeaderInfo* hi) {
  if (setjmp(png_jmpbuf(png))) return 0;
  png_read_info(png, info);
  int interlace = 0;
  png_get_IHDR(png, info, &hi->width, &hi->height, &hi->bit_depth, &hi->colour_type, &interlace, nullptr,
               nullptr);
  if (mode == Mode::kRgb8) {
    if (hi->colour_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((hi->colour_type & PNG_COLOR_MASK_COLOR) == 0 && hi->bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (hi->bit_depth == 16) {
#ifdef PNG_READ_SCALE_16_TO_8_SUPPORTED
      png_set_scale_16(png);
#else
      png_set_strip_16(png);
#endif
    }
    if ((hi->colour_type & PNG_COLOR_MASK_COLOR) == 0) png_set_gray_to_rgb(png);
  }
  if (mode != Mode::kInfo) {
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
  }
  hi->out_bit_depth = png_get_bit_depth(png, info);
  hi->out_channels = png_get_channels(png, info);
  hi->rowbytes = png_get_rowbytes(png, info);
  return 1;
}

int read_rows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return 0;
  png_read_image(png, rows);
  png_read_end(png, info);  // also checks the chunks after the image data (IEND, CRCs)
  return 1;
}

const char* colour_type_name(int t) {
  switch (t) {
    case PNG_COLOR_TYPE_GRAY: return "grey";
    case PNG_COLOR_TYPE_RGB: return "RGB";
    case PNG_COLOR_TYPE_PALETTE: return "palette";
    case PNG_COLOR_TYPE_GRAY_ALPHA: return "grey+alpha";
    case PNG_COLOR_TYPE_RGB_ALPHA: return "RGBA";
  }
  return "unknown colour type";
}

struct ReadStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~ReadStructs() {
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
  }
};

std::string libpng_message(const std::string& path, const MemoryReader& rd, const ErrorState& st) {
  if (rd.truncated) return path + ": truncated PNG data (libpng: " + st.msg + ")";
  return path + ": corrupt PNG data (libpng: " + st.msg + ")";
}

// Reads the file and decodes it into `bytes` (rowbytes * height) according to `mode`.
bool decode(const std::string& path, Mode mode, std::vector<unsigned char>& bytes, HeaderInfo& hi,
            std::string& err) {
  std::string data;
  if (!detail::read_file(path, data, err)) return false;
  if (data.empty()) {
    err = path + ": empty file, expected a PNG image";
    return false;
  }
  if (data.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(data.data()), 0, 8) != 0) {
    err = path + ": not a PNG file (bad signature)";
    return false;
  }
  ErrorState st;
  st.msg[0] = '\0';
  MemoryReader rd{reinterpret_cast<const unsigned char*>(data.data()), data.size(), 0, false};
  ReadStructs s;
  s.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st, on_error, on_warning);
  if (s.png) s.info = png_create_info_struct(s.png);
  if (!s.png || !s.info) {
    err = path + ": cannot initialise libpng";
    return false;
  }
  png_set_read_fn(s.png, &rd, on_read);
  png_set_user_limits(s.png, 1u << 16, 1u << 16);
  hi = HeaderInfo{};
  if (!read_header(s.png, s.info, mode, &hi)) {
    err = libpng_message(path, rd, st);
    return false;
  }
  if (mode == Mode::kInfo) return true;
  if (mode == Mode::kU16 && (hi.bit_depth != 16 || hi.colour_type != PNG_COLOR_TYPE_GRAY)) {
    err = format("%s: expected a 16-bit grey PNG, got %d-bit %s", path.c_str(), hi.bit_depth,
                 colour_type_name(hi.colour_type));
    return false;
  }
  if (mode == Mode::kRgb8 && (hi.out_bit_depth != 8 || (hi.out_channels != 3 && hi.out_channels != 4))) {
    err = format("%s: cannot convert %d-bit %s to 8-bit RGB", path.c_str(), hi.bit_depth,
                 colour_type_name(hi.colour_type));
    return false;
  }
  // zlib cannot expand more than ~1032:1, so a header promising more pixels than the file could
  // hold is corrupt: refuse before allocating.
  const unsigned long long need = (unsigned long long)hi.rowbytes * hi.height;
  const unsigned long long can = 1100ull * data.size() + 65536ull;
  if (need > can) {
    err = format("%s: header says %ux%u pixels, impossible for a %zu-byte file", path.c_str(),
                 unsigned(hi.width), unsigned(hi.height), data.size());
    return false;
  }
  // On 32-bit boards size_t would wrap before the allocation: refuse instead.
  if (need > std::numeric_limits<std::size_t>::max() / 2) {
    err = format("%s: a %ux%u image is too large for this machine", path.c_str(), unsigned(hi.width),
                 unsigned(hi.height));
    return false;
  }
  bytes.assign(std::size_t(need), 0);
  std::vector<png_bytep> rows(hi.height);
  for (png_uint_32 y = 0; y < hi.height; ++y) rows[y] = bytes.data() + std::size_t(y) * hi.rowbytes;
  if (!read_rows(s.png, s.info, rows.data())) {
    err = libpng_message(path, rd, st);
    return false;
  }
  return true;
}

struct WriteStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~WriteStructs() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
  }
};

int write_image(png_structp png, png_infop info, std::FILE* f, int w, int h, int bit_depth, int colour_type,
                png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return 0;
  png_init_io(png, f);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), bit_depth, colour_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return 1;
}

// `bytes` holds h rows of w * channels * (bit_depth / 8) bytes, 16-bit samples big-endian (PNG order).
bool encode(const std::string& path, const std::vector<unsigned char>& bytes, int w, int h, int bit_depth,
            int colour_type, std::string& err) {
  const std::size_t rowbytes = bytes.size() / std::size_t(h);
  std::vector<png_bytep> rows(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) rows[std::size_t(y)] = const_cast<png_bytep>(bytes.data()) + std::size_t(y) * rowbytes;
  ErrorState st;
  st.msg[0] = '\0';
  WriteStructs s;
  s.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &st, on_error, on_warning);
  if (s.png) s.info = png_create_info_struct(s.png);
  if (!s.png || !s.info) {
    err = path + ": cannot initialise libpng";
    return false;
  }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    err = path + ": cannot create (" + std::strerror(errno) + ")";
    return false;
  }
  const int ok = write_image(s.png, s.info, f, w, h, bit_depth, colour_type, rows.data());
  const bool closed = std::fclose(f) == 0;
  if (!ok) {
    err = path + ": cannot write PNG (libpng: " + st.msg + ")";
    return false;
  }
  if (!closed) {
    err = path + ": write failed (" + std::strerror(errno) + ")";
    return false;
  }
  return true;
}

bool check_size(const std::string& path, std::size_t n, int w, int h, std::string& err) {
  if (w <= 0 || h <= 0 || w > (1 << 16) || h > (1 << 16)) {
    err = format("%s: cannot write a %dx%d PNG", path.c_str(), w, h);
    return false;
  }
  if (n != std::size_t(w) * std::size_t(h)) {
    err = format("%s: %zu pixels given for a %dx%d image", path.c_str(), n, w, h);
    return false;
  }
  return true;
}


}  // namespace

bool read_png_info(const std::string& path, int& w, int& h, int& bit_depth, int& colour_type, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::vector<unsigned char> none;
    HeaderInfo hi;
    if (!decode(path, Mode::kInfo, none, hi, err)) return false;
    w = int(hi.width);
    h = int(hi.height);
    bit_depth = hi.bit_depth;
    colour_type = hi.colour_type;
    return true;
  });
}

bool read_png_u16(const std::string& path, std::vector<uint16_t>& px, int& w, int& h, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::vector<unsigned char> bytes;
    HeaderInfo hi;
    if (!decode(path, Mode::kU16, bytes, hi, err)) return false;
    w = int(hi.width);
    h = int(hi.height);
    px.resize(std::size_t(w) * std::size_t(h));
    for (std::size_t y = 0; y < std::size_t(h); ++y) {
      const unsigned char* row = bytes.data() + y * hi.rowbytes;
      uint16_t* out = px.data() + y * std::size_t(w);
      for (std::size_t x = 0; x < std::size_t(w); ++x) out[x] = uint16_t((row[2 * x] << 8) | row[2 * x + 1]);
    }
    return true;
  });
}

bool read_png_rgb8(const std::string& path, std::vector<Rgb8>& px, int& w, int& h, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::vector<unsigned char> bytes;
    HeaderInfo hi;
    if (!decode(path, Mode::kRgb8, bytes, hi, err)) return false;
    w = int(hi.width);
    h = int(hi.height);
    const std::size_t ch = std::size_t(hi.out_channels);
    px.resize(std::size_t(w) * std::size_t(h));
    for (std::size_t y = 0; y < std::size_t(h); ++y) {
      const unsigned char* row = bytes.data() + y * hi.rowbytes;
      Rgb8* out = px.data() + y * std::size_t(w);
      for (std::size_t x = 0; x < std::size_t(w); ++x) {
        out[x].r = row[ch * x];
        out[x].g = row[ch * x + 1];
        out[x].b = row[ch * x + 2];
      }
    }
    return true;
  });
}

bool write_png_u16(const std::string& path, const std::vector<uint16_t>& px, int w, int h, std::string& err) {
  return detail::guarded(path, err, [&] {
    if (!check_size(path, px.size(), w, h, err)) return false;
    std::vector<unsigned char> bytes(px.size() * 2);
    for (std::size_t i = 0; i < px.size(); ++i) {
      bytes[2 * i] = static_cast<unsigned char>(px[i] >> 8);  // PNG samples are big-endian
      bytes[2 * i + 1] = static_cast<unsigned char>(px[i] & 0xff);
    }
    return encode(path, bytes, w, h, 16, PNG_COLOR_TYPE_GRAY, err);
  });
}

bool write_png_rgb8(const std::string& path, const std::vector<Rgb8>& px, int w, int h, std::string& err) {
  return detail::guarded(path, err, [&] {
    if (!check_size(path, px.size(), w, h, err)) return false;
    std::vector<unsigned char> bytes(px.size() * 3);
    for (std::size_t i = 0; i < px.size(); ++i) {
      bytes[3 * i] = px[i].r;
      bytes[3 * i + 1] = px[i].g;
      bytes[3 * i + 2] = px[i].b;
    }
    return encode(path, bytes, w, h, 8, PNG_COLOR_TYPE_RGB, err);
  });
}

}  // namespace edgefuse::io
