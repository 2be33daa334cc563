// PNG readers/writers: round trips, real depth/colour files, and every kind of broken input.
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/io/png.hpp"
#include "formats_test_util.hpp"

using namespace edgefuse;
using namespace formats_test;

namespace {

std::vector<uint16_t> test_depth(int w, int h) {
  std::vector<uint16_t> px(std::size_t(w) * std::size_t(h));
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = uint16_t(i * 2654435761u >> 7);
  const uint16_t special[] = {0, 65535, 0x1234};  // 0x1234 checks byte order (not 0x3412)
  for (std::size_t i = 0; i < 3 && i < px.size(); ++i) px[i] = special[i];
  return px;
}

std::vector<Rgb8> test_colour(int w, int h) {
  std::vector<Rgb8> px(std::size_t(w) * std::size_t(h));
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = Rgb8{uint8_t(i), uint8_t(i * 7), uint8_t(255 - i)};
  return px;
}

const Reader read_u16 = [](const std::string& p, std::string& e) {
  std::vector<uint16_t> px;
  int w = 0, h = 0;
  return io::read_png_u16(p, px, w, h, e);
};
const Reader read_rgb = [](const std::string& p, std::string& e) {
  std::vector<Rgb8> px;
  int w = 0, h = 0;
  return io::read_png_rgb8(p, px, w, h, e);
};

uint32_t crc32(const std::string& s) {
  uint32_t c = 0xffffffffu;
  for (unsigned char b : s) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::string be32(uint32_t v) {
  return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}

// A chunk with a correct CRC, so that only the value under test is wrong.
std::string chunk(const std::string& type, const std::string& data) {
  return be32(uint32_t(data.size())) + type + data + be32(crc32(type + data));
}

// A zlib stream of stored (uncompressed) deflate blocks: lets the test build any PNG by hand.
std::string zlib_stored(const std::string& raw) {
  std::string z("\x78\x01", 2);
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(raw.size() - pos, 65535);
    const bool last = pos + n == raw.size();
    z += char(last ? 1 : 0);
    z += char(n & 0xff);
    z += char(n >> 8);
    z += char(~n & 0xff);
    z += char((~n >> 8) & 0xff);
    z += raw.substr(pos, n);
    pos += n;
  } while (pos < raw.size());
  uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  return z + be32((b << 16) | a);
}

// A PNG of `rows` (each row without its filter byte; filter 0 is added) and extra chunks before IDAT.
std::string make_png(int w, int h, int depth, int type, const std::vector<std::string>& rows,
                     const std::string& extra = std::string()) {
  std::string raw;
  for (const std::string& r : rows) raw += std::string(1, '\0') + r;
  const std::string ihdr = be32(uint32_t(w)) + be32(uint32_t(h)) + std::string{char(depth), char(type), 0, 0, 0};
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + extra + chunk("IDAT", zlib_stored(raw)) +
         chunk("IEND", "");
}

}  // namespace

TEST_GROUP(FormatsPng) {
  TempDir dir;
};

TEST(FormatsPng, RoundTripU16) {
  for (const auto& [w, h] : {std::pair<int, int>{7, 5}, {640, 480}, {1, 1}}) {
    const std::vector<uint16_t> px = test_depth(w, h);
    std::string err;
    const std::string path = dir.file("d.png");
    CHECK_TEXT(io::write_png_u16(path, px, w, h, err), err.c_str());
    std::vector<uint16_t> back;
    int bw = 0, bh = 0;
    CHECK_TEXT(io::read_png_u16(path, back, bw, bh, err), err.c_str());
    LONGS_EQUAL(w, bw);
    LONGS_EQUAL(h, bh);
    CHECK(back == px);
    int iw, ih, depth, type;
    CHECK_TEXT(io::read_png_info(path, iw, ih, depth, type, err), err.c_str());
    LONGS_EQUAL(16, depth);
    LONGS_EQUAL(0, type);
  }
}

TEST(FormatsPng, RoundTripRgb8) {
  const std::vector<Rgb8> px = test_colour(33, 17);
  std::string err;
  const std::string path = dir.file("c.png");
  CHECK_TEXT(io::write_png_rgb8(path, px, 33, 17, err), err.c_str());
  std::vector<Rgb8> back;
  int w = 0, h = 0;
  CHECK_TEXT(io::read_png_rgb8(path, back, w, h, err), err.c_str());
  LONGS_EQUAL(33, w);
  LONGS_EQUAL(17, h);
  for (std::size_t i = 0; i < px.size(); ++i) {
    LONGS_EQUAL(px[i].r, back[i].r);
    LONGS_EQUAL(px[i].g, back[i].g);
    LONGS_EQUAL(px[i].b, back[i].b);
  }
}

TEST(FormatsPng, Rgb8ReaderConvertsGrey16AndU16RejectsColour) {
  std::string err;
  const std::string grey = dir.file("g.png"), colour = dir.file("c.png");
  CHECK(io::write_png_u16(grey, {0, 0x8080, 0xffff, 0x0101}, 2, 2, err));
  std::vector<Rgb8> rgb;
  int w, h;
  CHECK_TEXT(io::read_png_rgb8(grey, rgb, w, h, err), err.c_str());
  LONGS_EQUAL(0, rgb[0].r);
  LONGS_EQUAL(128, rgb[1].g);
  LONGS_EQUAL(255, rgb[2].b);
  LONGS_EQUAL(1, rgb[3].r);
  CHECK(io::write_png_rgb8(colour, test_colour(4, 4), 4, 4, err));
  std::vector<uint16_t> d;
  CHECK_FAILS_NAMING(io::read_png_u16(colour, d, w, h, err), err, colour);
  CHECK_TEXT(err.find("expected a 16-bit grey PNG, got 8-bit RGB") != std::string::npos, err.c_str());
}

TEST(FormatsPng, WriterRejectsBadSizes) {
  std::string err;
  const std::string path = dir.file("bad.png");
  CHECK_FAILS_NAMING(io::write_png_u16(path, {1, 2, 3}, 2, 2, err), err, path);
  CHECK_FAILS_NAMING(io::write_png_rgb8(path, {}, 0, 0, err), err, path);
  CHECK_FAILS_NAMING(io::write_png_u16(dir.file("no/such/dir.png"), {1}, 1, 1, err), err, "no/such/dir.png");
}

TEST(FormatsPng, MissingEmptyGarbage) {
  const std::string sig("\x89PNG\r\n\x1a\n", 8);
  check_bad_files(dir, "x.png", read_u16, sig);
  check_bad_files(dir, "y.png", read_rgb, sig);
}

TEST(FormatsPng, TruncatedAtEveryLength) {
  std::string err;
  const std::string src = dir.file("src.png");
  CHECK(io::write_png_u16(src, test_depth(9, 7), 9, 7, err));
  check_truncations(dir, "cut.png", read_bytes(src), read_u16, true);
  CHECK(io::write_png_rgb8(src, test_colour(9, 7), 9, 7, err));
  check_truncations(dir, "cut.png", read_bytes(src), read_rgb, true);
  // A large image: cuts inside the compressed stream.
  CHECK(io::write_png_u16(src, test_depth(320, 240), 320, 240, err));
  const std::string big = read_bytes(src);
  check_truncations(dir, "cut.png", big, read_u16, true);
  const std::string path = dir.file("cut.png");
  write_bytes(path, big.substr(0, big.size() / 2));
  CHECK_FALSE(read_u16(path, err));
  CHECK_TEXT(err.find("truncated PNG data (libpng: ") != std::string::npos, err.c_str());
}

TEST(FormatsPng, CorruptBytesNeverCrash) {
  std::string err;
  const std::string src = dir.file("src.png");
  CHECK(io::write_png_u16(src, test_depth(16, 16), 16, 16, err));
  const std::string good = read_bytes(src);
  const std::string path = dir.file("flip.png");
  int failures = 0;
  for (std::size_t i = 8; i < good.size(); ++i) {
    std::string bad = good;
    bad[i] = char(bad[i] ^ 0x5a);
    write_bytes(path, bad);
    if (!read_u16(path, err)) {
      ++failures;
      CHECK_TEXT(err.find(path) != std::string::npos, err.c_str());
    }
  }
  // Every byte after the signature is covered by a chunk CRC (or is a length/CRC itself).
  LONGS_EQUAL(int(good.size() - 8), failures);
}

TEST(FormatsPng, HugeDimensionsRejectedBeforeAllocating) {
  const std::string sig("\x89PNG\r\n\x1a\n", 8);
  const std::string path = dir.file("huge.png");
  std::string err;
  // 60000 x 60000 16-bit grey (7.2 GB decoded) in a file of a few dozen bytes.
  std::string ihdr = be32(60000) + be32(60000) + std::string{16, 0, 0, 0, 0};
  write_bytes(path, sig + chunk("IHDR", ihdr) + chunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8)) +
                        chunk("IEND", ""));
  CHECK_FAILS_NAMING(read_u16(path, err), err, path);
  CHECK_TEXT(err.find("impossible") != std::string::npos, err.c_str());
  // Beyond libpng's user limit, and zero width: libpng's own errors, as messages.
  ihdr = be32(1000000) + be32(1) + std::string{16, 0, 0, 0, 0};
  write_bytes(path, sig + chunk("IHDR", ihdr) + chunk("IEND", ""));
  CHECK_FAILS_NAMING(read_u16(path, err), err, path);
  ihdr = be32(0) + be32(5) + std::string{16, 0, 0, 0, 0};
  write_bytes(path, sig + chunk("IHDR", ihdr) + chunk("IEND", ""));
  CHECK_FAILS_NAMING(read_u16(path, err), err, path);
  // Bit depth 16 with a palette is invalid.
  ihdr = be32(4) + be32(4) + std::string{16, 3, 0, 0, 0};
  write_bytes(path, sig + chunk("IHDR", ihdr) + chunk("IEND", ""));
  CHECK_FAILS_NAMING(read_rgb(path, err), err, path);
}

TEST(FormatsPng, RealDepthAndColour) {
  const std::string tum = edgefuse_test::require_data("tum_fr1_xyz_37");
  if (tum.empty()) return;
  std::vector<uint16_t> d;
  std::vector<Rgb8> c;
  int w = 0, h = 0;
  std::string err;
  CHECK_TEXT(io::read_png_u16(tum + "/depth/1305031102.160407.png", d, w, h, err), err.c_str());
  LONGS_EQUAL(640, w);
  LONGS_EQUAL(480, h);
  std::size_t valid = 0;
  uint16_t lo = 65535, hi = 0;
  for (uint16_t v : d)
    if (v) {
      ++valid;
      lo = v < lo ? v : lo;
      hi = v > hi ? v : hi;
    }
  // README: 0.90..3.72 m at 5000 per metre, ~75 % valid.
  CHECK(lo >= 4000 && hi <= 19000 && hi > 15000);
  CHECK(valid > d.size() / 2);
  CHECK_TEXT(io::read_png_rgb8(tum + "/rgb/1305031102.175304.png", c, w, h, err), err.c_str());
  LONGS_EQUAL(640 * 480, long(c.size()));
  // 8-bit colour is not depth.
  CHECK_FALSE(io::read_png_u16(tum + "/rgb/1305031102.175304.png", d, w, h, err));
  CHECK(err.find("1305031102.175304.png") != std::string::npos);
}

TEST(FormatsPng, Rgb8ReaderConvertsEveryColourType) {
  struct Case {
    const char* what;
    std::string png;
    Rgb8 first, second;
  };
  const std::string plte = chunk("PLTE", std::string("\x0a\x14\x1e\xc8\x64\x32", 6));
  const Case cases[] = {
      {"grey 8", make_png(2, 1, 8, 0, {std::string("\x00\xff", 2)}), {0, 0, 0}, {255, 255, 255}},
      {"grey 1", make_png(2, 1, 1, 0, {std::string("\x40", 1)}), {0, 0, 0}, {255, 255, 255}},
      {"grey+alpha 8", make_png(2, 1, 8, 4, {std::string("\x10\x00\x20\xff", 4)}), {16, 16, 16}, {32, 32, 32}},
      {"RGBA 8", make_png(2, 1, 8, 6, {std::string("\x01\x02\x03\x00\x04\x05\x06\xff", 8)}), {1, 2, 3}, {4, 5, 6}},
      {"RGB 16", make_png(2, 1, 16, 2, {std::string("\xff\xff\x00\x00\x80\x80\x01\x01\x02\x02\x03\x03", 12)}),
       {255, 0, 128}, {1, 2, 3}},
      {"palette 8", make_png(2, 1, 8, 3, {std::string("\x01\x00", 2)}, plte), {200, 100, 50}, {10, 20, 30}},
      {"palette 2 + tRNS", make_png(2, 1, 2, 3, {std::string("\x40", 1)}, plte + chunk("tRNS", std::string("\x00", 1))),
       {200, 100, 50}, {10, 20, 30}},  // 0x40: indices 1, 0 (top bits first); entry 0 transparent
  };
  const std::string path = dir.file("t.png");
  for (const Case& c : cases) {
    write_bytes(path, c.png);
    std::vector<Rgb8> px;
    int w = 0, h = 0;
    std::string err;
    CHECK_TEXT(io::read_png_rgb8(path, px, w, h, err), (std::string(c.what) + ": " + err).c_str());
    LONGS_EQUAL(2, w);
    LONGS_EQUAL(1, h);
    CHECK_TEXT(px[0].r == c.first.r && px[0].g == c.first.g && px[0].b == c.first.b, c.what);
    CHECK_TEXT(px[1].r == c.second.r && px[1].g == c.second.g && px[1].b == c.second.b, c.what);
    // None of these is 16-bit grey depth.
    std::vector<uint16_t> d;
    CHECK_FAILS_NAMING(io::read_png_u16(path, d, w, h, err), err, path);
  }
  // The hand-made 16-bit grey PNG reads as depth, big-endian samples.
  write_bytes(path, make_png(2, 1, 16, 0, {std::string("\x12\x34\xff\x00", 4)}));
  std::vector<uint16_t> d;
  int w = 0, h = 0;
  std::string err;
  CHECK_TEXT(io::read_png_u16(path, d, w, h, err), err.c_str());
  LONGS_EQUAL(0x1234, d[0]);
  LONGS_EQUAL(0xff00, d[1]);
  // A row of the wrong length (too little image data).
  write_bytes(path, make_png(4, 2, 16, 0, {std::string("\x12\x34", 2)}));
  CHECK_FAILS_NAMING(io::read_png_u16(path, d, w, h, err), err, path);
}
