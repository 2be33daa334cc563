// PCD: round trips in all three encodings (organised, with NaN points), hand-made files with
// foreign fields, the real PCL / mOSD clouds, and lying headers, LZF sizes and truncations.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "edgefuse/io/pcd.hpp"
#include "formats_test_util.hpp"

using namespace edgefuse;
using namespace formats_test;

namespace {

io::PointCloud organised_cloud(int w, int h, bool attrs) {
  io::PointCloud c;
  c.width = w;
  c.height = h;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const bool hole = (u + 2 * v) % 5 == 0;
      c.points.push_back(hole ? Vec3f(nan, nan, nan) : Vec3f(0.01f * float(u), -0.02f * float(v), 1.0f + 1e-4f * float(u * v)));
      if (!attrs) continue;
      c.normals.emplace_back(0.0f, -0.6f, 0.8f);
      c.colours.push_back(Rgba8{uint8_t(u * 9), uint8_t(v * 31), 200, uint8_t(hole ? 0 : 255)});
      c.labels.push_back(hole ? 0u : uint32_t(20 + u % 3));
    }
  return c;
}

bool same(float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); }

void check_same(const io::PointCloud& a, const io::PointCloud& b) {
  LONGS_EQUAL(a.width, b.width);
  LONGS_EQUAL(a.height, b.height);
  LONGS_EQUAL(long(a.points.size()), long(b.points.size()));
  LONGS_EQUAL(long(a.normals.size()), long(b.normals.size()));
  LONGS_EQUAL(long(a.colours.size()), long(b.colours.size()));
  LONGS_EQUAL(long(a.labels.size()), long(b.labels.size()));
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) CHECK(same(a.points[i][k], b.points[i][k]));
    if (!a.normals.empty())
      for (int k = 0; k < 3; ++k) CHECK(same(a.normals[i][k], b.normals[i][k]));
    if (!a.colours.empty()) {
      LONGS_EQUAL(a.colours[i].r, b.colours[i].r);
      LONGS_EQUAL(a.colours[i].g, b.colours[i].g);
      LONGS_EQUAL(a.colours[i].b, b.colours[i].b);
      LONGS_EQUAL(a.colours[i].a, b.colours[i].a);
    }
    if (!a.labels.empty()) LONGS_EQUAL(a.labels[i], b.labels[i]);
  }
}

const Reader read_pcd = [](const std::string& p, std::string& e) {
  io::PointCloud c;
  return io::read_pcd(p, c, e);
};

std::string le32(uint32_t v) { return std::string{char(v), char(v >> 8), char(v >> 16), char(v >> 24)}; }
std::string lef(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return le32(u);
}

std::string header(const std::string& fields, const std::string& size, const std::string& type,
                   const std::string& count, const std::string& wh_points, const std::string& data) {
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type + "\nCOUNT " + count +
         "\n" + wh_points + "VIEWPOINT 0 0 0 1 0 0 0\nDATA " + data + "\n";
}
const std::string kXyz = "x y z", kSize3 = "4 4 4", kType3 = "F F F", kCount3 = "1 1 1";

}  // namespace

TEST_GROUP(FormatsPcd) {
  TempDir dir;
};

TEST(FormatsPcd, RoundTripAllEncodingsOrganised) {
  for (io::PcdEncoding enc : {io::PcdEncoding::kBinary, io::PcdEncoding::kAscii, io::PcdEncoding::kBinaryCompressed})
    for (bool attrs : {false, true}) {
      const io::PointCloud c = organised_cloud(16, 12, attrs);
      const std::string path = dir.file("c.pcd");
      std::string err;
      CHECK_TEXT(io::write_pcd(path, c, err, enc), err.c_str());
      io::PointCloud back;
      CHECK_TEXT(io::read_pcd(path, back, err), err.c_str());
      check_same(c, back);
    }
  // Unorganised (width 0 means "points.size() x 1") and empty clouds.
  io::PointCloud u = organised_cloud(7, 1, true);
  u.width = 0;
  u.height = 0;
  for (io::PcdEncoding enc : {io::PcdEncoding::kBinary, io::PcdEncoding::kAscii, io::PcdEncoding::kBinaryCompressed}) {
    std::string err;
    io::PointCloud back;
    CHECK_TEXT(io::write_pcd(dir.file("u.pcd"), u, err, enc), err.c_str());
    CHECK_TEXT(io::read_pcd(dir.file("u.pcd"), back, err), err.c_str());
    LONGS_EQUAL(7, back.width);
    LONGS_EQUAL(1, back.height);
    CHECK_TEXT(io::write_pcd(dir.file("e.pcd"), io::PointCloud(), err, enc), err.c_str());
    CHECK_TEXT(io::read_pcd(dir.file("e.pcd"), back, err), err.c_str());
    CHECK(back.points.empty());
  }
}

TEST(FormatsPcd, ForeignFieldsAreSkippedByType) {
  // ascii: label first, a 3-count padding field, float-text rgb (old PCL) and integer-bit rgb (new PCL),
  // doubles, int16 and a curvature that is ignored.
  const std::string path = dir.file("f.pcd");
  write_bytes(path, header("label x y z _ rgb normal_x normal_y normal_z curvature s", "4 8 8 8 1 4 4 4 4 4 2",
                           "U F F F U F F F F F I", "1 1 1 1 3 1 1 1 1 1 1", "WIDTH 2\nHEIGHT 1\nPOINTS 2\n", "ascii") +
                        "7 1.5 -2.25 3 0 0 0 4278190080 0 0 1 0.01 -32768\n"
                        "0 nan nan nan 0 0 0 2.34180515e-38 1 0 0 0 32767\n");
  io::PointCloud c;
  std::string err;
  CHECK_TEXT(io::read_pcd(path, c, err), err.c_str());
  LONGS_EQUAL(2, long(c.points.size()));
  DOUBLES_EQUAL(-2.25, c.points[0].y(), 0);
  CHECK(std::isnan(c.points[1].z()));
  LONGS_EQUAL(7, c.labels[0]);
  LONGS_EQUAL(1, long(c.normals[0].z()));
  LONGS_EQUAL(0, c.colours[0].r);  // 0xFF000000: only the unused top byte set
  LONGS_EQUAL(255, c.colours[0].a);
  LONGS_EQUAL(255, c.colours[1].r);  // 2.34180515e-38 = 0x00FF0000 (red), the float form
  LONGS_EQUAL(0, c.colours[1].g);

  // binary, with a uint8 padding field between x and y and a double field after z.
  std::string body;
  for (int i = 0; i < 3; ++i) body += lef(float(i)) + std::string(1, char(0xab)) + lef(2.0f * float(i)) + lef(-1.0f) +
                                      std::string(8, char(i));
  write_bytes(path, header("x pad y z d", "4 1 4 4 8", "F U F F F", "1 1 1 1 1", "WIDTH 3\nHEIGHT 1\n", "binary") + body);
  CHECK_TEXT(io::read_pcd(path, c, err), err.c_str());
  LONGS_EQUAL(3, long(c.points.size()));
  DOUBLES_EQUAL(4.0, c.points[2].y(), 0);
  DOUBLES_EQUAL(-1.0, c.points[2].z(), 0);
  CHECK(c.colours.empty() && c.labels.empty() && c.normals.empty());
}

TEST(FormatsPcd, LyingHeaders) {
  const std::string xyz = header(kXyz, kSize3, kType3, kCount3, "WIDTH 640\nHEIGHT 480\nPOINTS 307200\n", "binary");
  std::string data;
  for (int i = 0; i < 1024 * 3; ++i) data += lef(0.5f);
  check_bad_text(dir, "h.pcd", xyz + data, read_pcd, "header says 307200 points but the data holds 1024");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH 640\nHEIGHT 480\nPOINTS 1000\n", "binary"),
                 read_pcd, "POINTS 1000 disagrees with WIDTH x HEIGHT = 640 x 480 = 307200");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH -5\nHEIGHT 1\n", "binary"), read_pcd,
                 "WIDTH must be one integer in 0..2147483647, got '-5'");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH 4294967296\nHEIGHT 1\n", "binary"),
                 read_pcd, "WIDTH must be one integer");
  check_bad_text(dir, "h.pcd",
                 header(kXyz, kSize3, kType3, kCount3, "WIDTH 2147483647\nHEIGHT 2147483647\n", "binary") + data,
                 read_pcd, "header says 4611686014132420609 points but the data holds 1024");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH 2\nHEIGHT 1\n", "binary_zstd"), read_pcd,
                 "unknown DATA encoding 'binary_zstd'");
  check_bad_text(dir, "h.pcd", header(kXyz, "4 4", kType3, kCount3, "WIDTH 2\n", "binary"), read_pcd,
                 "SIZE has 2 entries but FIELDS has 3");
  check_bad_text(dir, "h.pcd", header(kXyz, "4 4 3", kType3, kCount3, "WIDTH 2\n", "binary"), read_pcd,
                 "SIZE of field 'z' must be 1, 2, 4 or 8, got '3'");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, "F F X", kCount3, "WIDTH 2\n", "binary"), read_pcd,
                 "TYPE of field 'z' must be F, I or U, got 'X'");
  check_bad_text(dir, "h.pcd", header(kXyz, "4 4 2", kType3, kCount3, "WIDTH 2\n", "binary"), read_pcd,
                 "field 'z' has TYPE F with SIZE 2");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, "1 0 1", "WIDTH 2\n", "binary"), read_pcd,
                 "COUNT of field 'y' must be in 1..1048576, got '0'");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, "1 99999999999 1", "WIDTH 2\n", "binary"), read_pcd,
                 "COUNT of field 'y'");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, "1 2 1", "WIDTH 1\n", "binary") + data, read_pcd,
                 "field 'y' must have COUNT 1, got 2");
  check_bad_text(dir, "h.pcd", header("x y w", kSize3, kType3, kCount3, "WIDTH 1\n", "binary") + data, read_pcd,
                 "PCD has no x, y and z fields");
  check_bad_text(dir, "h.pcd", header("x y z rgb", "4 4 4 2", "F F F U", "1 1 1 1", "WIDTH 1\n", "binary") + data,
                 read_pcd, "field 'rgb' must be one 4-byte packed colour");
  check_bad_text(dir, "h.pcd", "VERSION 0.7\nSIZE 4 4 4\nFIELDS x y z\n", read_pcd, "SIZE before FIELDS");
  check_bad_text(dir, "h.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nDATA binary\n", read_pcd,
                 "header lacks FIELDS, SIZE, TYPE or WIDTH before DATA");
  check_bad_text(dir, "h.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\n", read_pcd,
                 "no DATA line");
  check_bad_text(dir, "h.pcd", "VERSION 0.7\nFIELDS\n", read_pcd, "FIELDS lists no fields");
  check_bad_text(dir, "h.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH 1\n", "binary").replace(0, 11, "GARBAGE 1\n"),
                 read_pcd, "not a PCD header line: 'GARBAGE 1'");
  check_bad_text(dir, "h.pcd", "VERSION 0.7\nVIEWPOINT 0 0 0 1 0 0\n", read_pcd, "VIEWPOINT must have 7 numbers");
}

TEST(FormatsPcd, LyingLzfSizes) {
  const std::string hdr = header(kXyz, kSize3, kType3, kCount3, "WIDTH 100\nHEIGHT 1\n", "binary_compressed");
  std::string err;
  // A valid file to take the compressed block from.
  io::PointCloud c = organised_cloud(100, 1, false);
  CHECK(io::write_pcd(dir.file("ok.pcd"), c, err, io::PcdEncoding::kBinaryCompressed));
  const std::string good = read_bytes(dir.file("ok.pcd"));
  const std::size_t at = good.find("DATA binary_compressed\n") + 23;
  const uint32_t csize = uint32_t(uint8_t(good[at])) | uint32_t(uint8_t(good[at + 1])) << 8 |
                         uint32_t(uint8_t(good[at + 2])) << 16 | uint32_t(uint8_t(good[at + 3])) << 24;
  const std::string block = good.substr(at + 8);
  LONGS_EQUAL(long(csize), long(block.size()));
  check_bad_text(dir, "z.pcd", hdr + "\x01\x02", read_pcd, "lacks its 8-byte size header");
  check_bad_text(dir, "z.pcd", hdr + le32(csize + 1) + le32(1200) + block, read_pcd,
                 "truncated PCD: LZF block of " + std::to_string(csize + 1) + " bytes but only");
  check_bad_text(dir, "z.pcd", hdr + le32(0xffffffffu) + le32(1200) + block, read_pcd, "truncated PCD: LZF block");
  check_bad_text(dir, "z.pcd", hdr + le32(csize) + le32(1199) + block, read_pcd,
                 "LZF header says 1199 uncompressed bytes but 100 points x 12 bytes = 1200");
  check_bad_text(dir, "z.pcd", hdr + le32(csize) + le32(0xffffffffu) + block, read_pcd, "LZF header says 4294967295");
  const std::string big = header(kXyz, kSize3, kType3, kCount3, "WIDTH 1000000\nHEIGHT 1\n", "binary_compressed");
  check_bad_text(dir, "z.pcd", big + le32(10) + le32(12000000) + std::string(10, '\0'), read_pcd, "LZF sizes are impossible");
  // A block that decompresses to fewer bytes than promised (its data is the header's 1200 bytes
  // cut short), and a back-reference before the start of the output.
  const std::string literals("\x00w\x00x\x00y\x00z", 8);  // control 0: one literal byte
  check_bad_text(dir, "z.pcd", hdr + le32(13) + le32(1200) + std::string("\x03\x01\x02\x03\x04", 5) + literals,
                 read_pcd, "corrupt LZF data (decompressed 8 of 1200 bytes)");
  check_bad_text(dir, "z.pcd", hdr + le32(13) + le32(1200) + std::string("\x00A\xe0\x10\x20", 5) + literals, read_pcd,
                 "corrupt LZF data");
  // Every byte of the block flipped in turn: an error or other numbers, never a crash.
  for (std::size_t i = 0; i < block.size(); ++i) {
    std::string bad = block;
    bad[i] = char(bad[i] ^ 0xa5);
    write_bytes(dir.file("flip.pcd"), hdr + le32(csize) + le32(1200) + bad);
    if (!read_pcd(dir.file("flip.pcd"), err)) CHECK_TEXT(err.find("flip.pcd") != std::string::npos, err.c_str());
  }
}

TEST(FormatsPcd, BadAsciiBodies) {
  const std::string hdr = header(kXyz, kSize3, kType3, kCount3, "WIDTH 2\nHEIGHT 1\n", "ascii");
  check_bad_text(dir, "a.pcd", hdr + "1.0 2.0 3.0\n4.0 5.0\n", read_pcd, "a.pcd:12: 2 values, expected 3");
  check_bad_text(dir, "a.pcd", hdr + "1 2 3\n4 five 6\n", read_pcd, "a.pcd:12: bad value 'five' for field 'y' (F4)");
  check_bad_text(dir, "a.pcd", hdr + "1.0 2.0 3.0\n", read_pcd, "header says 2 points but the data holds 1");
  check_bad_text(dir, "a.pcd", hdr + "1 2 3\n", read_pcd, "header says 2 points but the data (6 bytes) cannot hold them");
  check_bad_text(dir, "a.pcd", hdr + "1 2 3\n4 5 6\n7 8 9\n", read_pcd, "a.pcd:13: header says 2 points but the data holds more");
  const std::string lab = header("x y z label", "4 4 4 1", "F F F U", "1 1 1 1", "WIDTH 1\n", "ascii");
  check_bad_text(dir, "a.pcd", lab + "1 2 3 256\n", read_pcd, "bad value '256' for field 'label' (U1)");
  check_bad_text(dir, "a.pcd", lab + "1 2 3 -1\n", read_pcd, "bad value '-1' for field 'label'");
  check_bad_text(dir, "a.pcd", header(kXyz, kSize3, kType3, kCount3, "WIDTH 100000000\n", "ascii") + "1 2 3\n", read_pcd,
                 "header says 100000000 points but the data (6 bytes) cannot hold them");
}

TEST(FormatsPcd, MissingEmptyGarbageTruncated) {
  check_bad_files(dir, "g.pcd", read_pcd, "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\n");
  check_bad_files(dir, "g.pcd", read_pcd, header(kXyz, kSize3, kType3, kCount3, "WIDTH 10\nHEIGHT 10\n", "binary_compressed"));
  const io::PointCloud c = organised_cloud(20, 10, true);
  std::string err;
  const std::string src = dir.file("src.pcd");
  for (io::PcdEncoding enc : {io::PcdEncoding::kBinary, io::PcdEncoding::kBinaryCompressed, io::PcdEncoding::kAscii}) {
    CHECK(io::write_pcd(src, c, err, enc));
    check_truncations(dir, "cut.pcd", read_bytes(src), read_pcd, enc != io::PcdEncoding::kAscii);
  }
}

TEST(FormatsPcd, WriterRejectsInconsistentInput) {
  std::string err;
  io::PointCloud c = organised_cloud(4, 3, true);
  c.width = 5;
  CHECK_FAILS_NAMING(io::write_pcd(dir.file("w.pcd"), c, err), err, "w.pcd");
  c = organised_cloud(4, 3, true);
  c.labels.pop_back();
  CHECK_FAILS_NAMING(io::write_pcd(dir.file("w.pcd"), c, err), err, "w.pcd");
}

TEST(FormatsPcd, RealPclMilkScene) {
  const std::string root = edgefuse_test::require_data("pcl_milk_recognition");
  if (root.empty()) return;
  io::PointCloud scene, milk, milk_colour;
  std::string err;
  CHECK_TEXT(io::read_pcd(root + "/milk_recognition/milk_cartoon_all_small_clorox.pcd", scene, err), err.c_str());
  LONGS_EQUAL(640, scene.width);
  LONGS_EQUAL(480, scene.height);
  std::size_t finite = 0;
  float zmin = 1e9f, zmax = -1e9f;
  for (const Vec3f& p : scene.points)
    if (p.allFinite()) {
      ++finite;
      zmin = std::min(zmin, p.z());
      zmax = std::max(zmax, p.z());
    }
  LONGS_EQUAL(241407, long(finite));  // README (and Open3D 0.16)
  DOUBLES_EQUAL(0.501, zmin, 1e-4);
  DOUBLES_EQUAL(2.063, zmax, 1e-4);
  // First finite point, as Open3D reads it: index 10814, colour (88, 85, 68).
  CHECK(!scene.points[10813].allFinite() && scene.points[10814].allFinite());
  CHECK((scene.points[10814] - Vec3f(0.9656457f, -0.8480229f, 1.992f)).norm() < 1e-6f);
  LONGS_EQUAL(88, scene.colours[10814].r);
  LONGS_EQUAL(85, scene.colours[10814].g);
  LONGS_EQUAL(68, scene.colours[10814].b);
  CHECK_TEXT(io::read_pcd(root + "/milk_recognition/milk.pcd", milk, err), err.c_str());
  CHECK_TEXT(io::read_pcd(root + "/milk_recognition/milk_color.pcd", milk_colour, err), err.c_str());
  LONGS_EQUAL(13704, long(milk.points.size()));
  CHECK(milk.colours.empty());
  LONGS_EQUAL(13704, long(milk_colour.colours.size()));
  CHECK(milk.points == milk_colour.points);
  LONGS_EQUAL(103, milk_colour.colours[0].r);
  // Round trip of the real scene through our writer, every encoding.
  for (io::PcdEncoding enc : {io::PcdEncoding::kBinaryCompressed, io::PcdEncoding::kBinary}) {
    io::PointCloud back;
    CHECK_TEXT(io::write_pcd(dir.file("scene.pcd"), scene, err, enc), err.c_str());
    CHECK_TEXT(io::read_pcd(dir.file("scene.pcd"), back, err), err.c_str());
    check_same(scene, back);
  }
}

TEST(FormatsPcd, RealMosdLabelledScenes) {
  const std::string root = edgefuse_test::require_data("mosd_learn");
  if (root.empty()) return;
  int files = 0;
  for (int n = 0; n <= 44; ++n) {
    const std::string path = root + "/learn" + std::to_string(n) + ".pcd";
    if (!std::filesystem::exists(path)) continue;
    ++files;
    io::PointCloud c;
    std::string err;
    CHECK_TEXT(io::read_pcd(path, c, err), err.c_str());
    LONGS_EQUAL(640, c.width);
    LONGS_EQUAL(480, c.height);
    LONGS_EQUAL(640 * 480, long(c.labels.size()));
    LONGS_EQUAL(640 * 480, long(c.colours.size()));
    std::size_t finite = 0, object_points = 0, bad_labels = 0;
    for (std::size_t i = 0; i < c.points.size(); ++i) {
      const bool ok = c.points[i].allFinite();
      finite += ok;
      // README: label 0 = invalid (NaN) point, 1-9 table, >= 20 objects.
      bad_labels += (!ok && c.labels[i] != 0) || (c.labels[i] >= 10 && c.labels[i] < 20);
      object_points += c.labels[i] >= 20;
    }
    LONGS_EQUAL(0, long(bad_labels));
    CHECK(object_points > 0);
    if (n == 0) {
      LONGS_EQUAL(182292, long(finite));  // as Open3D 0.16 reads it
      CHECK((c.points[99213] - Vec3f(-0.7455248f, -0.2055362f, 1.277f)).norm() < 1e-6f);
      LONGS_EQUAL(205, c.colours[99213].r);
      LONGS_EQUAL(169, c.colours[99213].b);
    }
  }
  LONGS_EQUAL(23, files);
}
