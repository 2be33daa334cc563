// PLY points and meshes: round trips in both encodings, the mesh collector, real models, and
// broken headers/bodies (counts larger than the file, bad indices, truncation, garbage).
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "edgefuse/io/mesh_collector.hpp"
#include "edgefuse/io/ply.hpp"
#include "formats_test_util.hpp"

using namespace edgefuse;
using namespace formats_test;

namespace {

io::PointCloud test_cloud(std::size_t n, bool attrs) {
  io::PointCloud c;
  c.width = int(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.points.emplace_back(0.001f * float(i), -1.5f + float(i), 1e-7f * float(i * i));
    if (!attrs) continue;
    c.normals.emplace_back(0.0f, 0.6f, 0.8f);
    c.colours.push_back(Rgba8{uint8_t(i), uint8_t(2 * i), uint8_t(255 - i), uint8_t(i % 2 ? 255 : 0)});
    c.labels.push_back(uint32_t(i * 1000003u));
    c.support.push_back(uint8_t(i * 7 % 256));  // per-point evidence of fusion
  }
  if (n > 3) c.points[3] = Vec3f(std::numeric_limits<float>::quiet_NaN(), 0, 0);
  return c;
}

io::TriangleMesh test_mesh() {
  // A tetrahedron.
  io::TriangleMesh m;
  m.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 0, 1)};
  m.normals = {Vec3f(-1, -1, -1).normalized(), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 0, 1)};
  m.colours = {Rgba8{1, 2, 3, 255}, Rgba8{4, 5, 6, 255}, Rgba8{7, 8, 9, 0}, Rgba8{10, 11, 12, 255}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

bool same(const Vec3f& a, const Vec3f& b) {
  for (int k = 0; k < 3; ++k)
    if (!(a[k] == b[k] || (std::isnan(a[k]) && std::isnan(b[k])))) return false;
  return true;
}

void check_same_cloud(const io::PointCloud& a, const io::PointCloud& b) {
  LONGS_EQUAL(long(a.points.size()), long(b.points.size()));
  LONGS_EQUAL(long(a.normals.size()), long(b.normals.size()));
  LONGS_EQUAL(long(a.colours.size()), long(b.colours.size()));
  LONGS_EQUAL(long(a.labels.size()), long(b.labels.size()));
  LONGS_EQUAL(long(a.support.size()), long(b.support.size()));
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    CHECK(same(a.points[i], b.points[i]));
    if (!a.normals.empty()) CHECK(same(a.normals[i], b.normals[i]));
    if (!a.colours.empty()) {
      LONGS_EQUAL(a.colours[i].r, b.colours[i].r);
      LONGS_EQUAL(a.colours[i].b, b.colours[i].b);
      LONGS_EQUAL(a.colours[i].a, b.colours[i].a);
    }
    if (!a.labels.empty()) LONGS_EQUAL(a.labels[i], b.labels[i]);
    if (!a.support.empty()) LONGS_EQUAL(a.support[i], b.support[i]);
  }
}

const Reader read_cloud = [](const std::string& p, std::string& e) {
  io::PointCloud c;
  return io::read_ply(p, c, e);
};
const Reader read_mesh = [](const std::string& p, std::string& e) {
  io::TriangleMesh m;
  return io::read_ply(p, m, e);
};

const char* kAsciiHeader = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

}  // namespace

TEST_GROUP(FormatsPly) {
  TempDir dir;
};

TEST(FormatsPly, PointsRoundTripBothEncodings) {
  for (io::PlyEncoding enc : {io::PlyEncoding::kBinaryLittleEndian, io::PlyEncoding::kAscii})
    for (bool attrs : {false, true}) {
      const io::PointCloud c = test_cloud(50, attrs);
      const std::string path = dir.file("c.ply");
      std::string err;
      CHECK_TEXT(io::write_ply(path, c, err, enc), err.c_str());
      io::PointCloud back;
      CHECK_TEXT(io::read_ply(path, back, err), err.c_str());
      check_same_cloud(c, back);
      LONGS_EQUAL(50, back.width);
      LONGS_EQUAL(1, back.height);
    }
}

TEST(FormatsPly, MeshRoundTripBothEncodings) {
  for (io::PlyEncoding enc : {io::PlyEncoding::kBinaryLittleEndian, io::PlyEncoding::kAscii}) {
    const io::TriangleMesh m = test_mesh();
    const std::string path = dir.file("m.ply");
    std::string err;
    CHECK_TEXT(io::write_ply(path, m, err, enc), err.c_str());
    io::TriangleMesh back;
    CHECK_TEXT(io::read_ply(path, back, err), err.c_str());
    LONGS_EQUAL(4, long(back.vertices.size()));
    LONGS_EQUAL(4, long(back.normals.size()));
    LONGS_EQUAL(4, long(back.colours.size()));
    LONGS_EQUAL(0, back.colours[2].a);  // never seen in colour stays so
    LONGS_EQUAL(255, back.colours[3].a);
    CHECK(back.triangles == m.triangles);
    CHECK(same(back.normals[0], m.normals[0]));
    // Read as a cloud: the vertices.
    io::PointCloud c;
    CHECK_TEXT(io::read_ply(path, c, err), err.c_str());
    LONGS_EQUAL(4, long(c.points.size()));
  }
}

TEST(FormatsPly, CollectorFromMeshSink) {
  io::PlyMeshCollector col;
  MeshSink& sink = col;
  LONGS_EQUAL(0, sink.add_vertex(Vec3f(0, 0, 0), Vec3f(0, 0, 1), Rgba8{}));
  LONGS_EQUAL(1, sink.add_vertex(Vec3f(1, 0, 0), Vec3f(0, 0, 1), Rgba8{}));
  LONGS_EQUAL(2, sink.add_vertex(Vec3f(0, 1, 0), Vec3f(0, 0, 1), Rgba8{}));
  sink.add_triangle(0, 1, 2);
  const std::string path = dir.file("col.ply");
  std::string err;
  CHECK_TEXT(col.write(path, err), err.c_str());
  io::TriangleMesh m;
  CHECK_TEXT(io::read_ply(path, m, err), err.c_str());
  LONGS_EQUAL(1, long(m.triangles.size()));
  LONGS_EQUAL(0, long(m.colours.size()));  // no vertex seen in colour: no colour written
  col.mesh().colours[1] = Rgba8{9, 9, 9, 255};
  CHECK_TEXT(col.write(path, err), err.c_str());
  CHECK_TEXT(io::read_ply(path, m, err), err.c_str());
  LONGS_EQUAL(3, long(m.colours.size()));
}

TEST(FormatsPly, ReaderHandlesVariants) {
  const std::string path = dir.file("v.ply");
  std::string err;
  io::TriangleMesh m;
  // Quads are fan-triangulated; a foreign element and a list property inside vertex are skipped;
  // double coordinates, uchar colours without alpha, "vertex_index" and uint8/uint32 type names.
  write_bytes(path,
              "ply\r\nformat ascii 1.0\r\ncomment x\r\nobj_info y\r\nelement material 1\r\nproperty uchar k\r\n"
              "property list uchar float w\r\nelement vertex 4\r\nproperty double x\r\nproperty double y\r\n"
              "property double z\r\nproperty list uint8 int junk\r\nproperty uchar red\r\nproperty uchar green\r\n"
              "property uchar blue\r\nelement face 1\r\nproperty uint8 flags\r\n"
              "property list uint8 uint32 vertex_index\r\nend_header\r\n"
              "7 2 0.5 0.25\r\n0 0 0 0 1 2 3\r\n1 0 0 2 5 6 4 5 6\r\n1 1 0 0 7 8 9\r\n0 1 0 0 0 0 0\r\n9 4 0 1 2 3\r\n");
  CHECK_TEXT(io::read_ply(path, m, err), err.c_str());
  LONGS_EQUAL(4, long(m.vertices.size()));
  LONGS_EQUAL(2, long(m.triangles.size()));
  CHECK((m.triangles[1] == std::array<uint32_t, 3>{0, 2, 3}));
  LONGS_EQUAL(255, m.colours[0].a);
  LONGS_EQUAL(8, m.colours[2].g);
  CHECK(m.normals.empty());
  // Zero vertices is a valid (empty) file.
  write_bytes(path, "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n");
  CHECK_TEXT(io::read_ply(path, m, err), err.c_str());
  CHECK(m.vertices.empty());
}

TEST(FormatsPly, BadHeaders) {
  const std::string v3 = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  check_bad_text(dir, "h.ply", "plx\nformat ascii 1.0\nend_header\n", read_cloud, "not a PLY file");
  check_bad_text(dir, "h.ply", "ply\nformat binary_big_endian 1.0\n" + v3 + "end_header\n", read_cloud,
                 "h.ply:2: unsupported PLY format 'binary_big_endian'");
  check_bad_text(dir, "h.ply", "ply\nformat foo 1.0\nend_header\n", read_cloud, "unsupported PLY format 'foo'");
  check_bad_text(dir, "h.ply", "ply\n" + v3 + "end_header\n", read_cloud, "no 'format' line");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\nelement vertex -5\nend_header\n", read_cloud,
                 "h.ply:3: expected 'element <name> <count>'");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n",
                 read_cloud, "h.ply:3:");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", read_cloud,
                 "property before any element");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3 + "property quad w\nend_header\n", read_cloud,
                 "h.ply:7: bad property line 'property quad w'");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3 + "element face 1\nproperty list float int v\nend_header\n",
                 read_mesh, "list count type must be an integer type");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3 + "element vertex 1\nend_header\n", read_cloud,
                 "element 'vertex' declared twice");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3 + "bogus line\nend_header\n", read_cloud,
                 "unexpected PLY header line 'bogus line'");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3, read_cloud, "no end_header");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
                 read_cloud, "lacks scalar x, y and z");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
                 read_mesh, "no 'vertex' element");
  check_bad_text(dir, "h.ply", "ply\nformat ascii 1.0\n" + v3 + "element face 1\nproperty int x\nend_header\n0 0 0\n1 1 1\n2 2 2\n5\n",
                 read_mesh, "no integer list property vertex_indices");
}

TEST(FormatsPly, CountsLargerThanTheFileFailFast) {
  // Four billion vertices in a 100-byte file must be refused before anything is allocated.
  const std::string hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                          "property float y\nproperty float z\nend_header\n";
  check_bad_text(dir, "big.ply", hdr + std::string(12, '\0'), read_cloud, "header says 4000000000 'vertex' entries");
  check_bad_text(dir, "big.ply",
                 "ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nproperty float y\n"
                 "property float z\nend_header\n0 0 0\n",
                 read_cloud, "cannot hold them");
  // An element with no properties but a huge count would loop forever.
  check_bad_text(dir, "big.ply", "ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\nend_header\n",
                 read_cloud, "element 'junk' has 18446744073709551615 entries but no properties");
  // A face whose list length (255) runs past the end of the file.
  std::string body(36, '\0');
  body += std::string("\xff\x00\x00\x00\x00", 5);
  check_bad_text(dir, "big.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + body,
                 read_mesh, "truncated PLY data");
  // A uint list length of 2^32 - 1.
  body = std::string(36, '\0') + std::string("\xff\xff\xff\xff\x00\x00\x00\x00", 8);
  check_bad_text(dir, "big.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n" + body,
                 read_mesh, "exceeds the file");
}

TEST(FormatsPly, BadBodies) {
  const std::string h = kAsciiHeader;
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", read_mesh,
                 "refers to vertex 3 but there are only 3 vertices");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", read_mesh, "negative vertex index");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", read_mesh, "face 0 has 2 vertices");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", read_mesh,
                 "element 'vertex' entry 1: bad value 'zero' for property 'y' (float)");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", read_mesh, "bad value '300' for property 'vertex_indices'");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n", read_mesh, "truncated PLY data");
  check_bad_text(dir, "b.ply", h + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", read_mesh, "element 'face' ends at entry 0 of 1");
}

TEST(FormatsPly, MissingEmptyGarbageTruncated) {
  check_bad_files(dir, "g.ply", read_cloud, "ply\nformat binary_little_endian 1.0\nelement vertex 100\n");
  check_bad_files(dir, "g.ply", read_mesh, "ply\n");
  std::string err;
  const std::string src = dir.file("src.ply");
  CHECK(io::write_ply(src, test_mesh(), err));
  check_truncations(dir, "cut.ply", read_bytes(src), read_mesh, true);
  CHECK(io::write_ply(src, test_cloud(200, true), err));
  check_truncations(dir, "cut.ply", read_bytes(src), read_cloud, true);
  CHECK(io::write_ply(src, test_mesh(), err, io::PlyEncoding::kAscii));
  check_truncations(dir, "cut.ply", read_bytes(src), read_mesh, false);
  // Flipped bytes in a binary body may give other numbers, never a crash.
  CHECK(io::write_ply(src, test_mesh(), err));
  const std::string good = read_bytes(src);
  for (std::size_t i = 0; i < good.size(); ++i) {
    std::string bad = good;
    bad[i] = char(bad[i] ^ 0xff);
    write_bytes(dir.file("flip.ply"), bad);
    if (!read_mesh(dir.file("flip.ply"), err)) CHECK_TEXT(err.find("flip.ply") != std::string::npos, err.c_str());
  }
}

TEST(FormatsPly, WriterRejectsInconsistentInput) {
  std::string err;
  io::PointCloud c = test_cloud(5, true);
  c.normals.pop_back();
  CHECK_FAILS_NAMING(io::write_ply(dir.file("w.ply"), c, err), err, "w.ply");
  c = test_cloud(5, true);
  c.support.pop_back();
  CHECK_FAILS_NAMING(io::write_ply(dir.file("w.ply"), c, err), err, "w.ply");
  io::TriangleMesh m = test_mesh();
  m.triangles.push_back({0, 1, 4});
  CHECK_FAILS_NAMING(io::write_ply(dir.file("w.ply"), m, err), err, "w.ply");
}

TEST(FormatsPly, RealModels) {
  const std::string rig = edgefuse_test::require_data("bin_rig_a");
  if (rig.empty()) return;
  std::string err;
  io::TriangleMesh can, box, lmo;
  CHECK_TEXT(io::read_ply(rig + "/models/box.ply", box, err), err.c_str());
  LONGS_EQUAL(24, long(box.vertices.size()));
  LONGS_EQUAL(12, long(box.triangles.size()));
  Vec3f lo = box.vertices[0], hi = box.vertices[0];
  for (const Vec3f& v : box.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  CHECK(((hi - lo) - Vec3f(0.060f, 0.040f, 0.025f)).cwiseAbs().maxCoeff() < 1e-5f);  // README: 60 x 40 x 25 mm
  CHECK_TEXT(io::read_ply(rig + "/models/can.ply", can, err), err.c_str());
  LONGS_EQUAL(22831, long(can.vertices.size()));
  LONGS_EQUAL(45666, long(can.triangles.size()));
  LONGS_EQUAL(22831, long(can.normals.size()));

  const std::string lm = edgefuse_test::require_data("lmo_can_frame");
  CHECK_TEXT(io::read_ply(lm + "/obj_000005.ply", lmo, err), err.c_str());  // ascii, millimetres, colours
  LONGS_EQUAL(22831, long(lmo.vertices.size()));
  LONGS_EQUAL(45666, long(lmo.triangles.size()));
  LONGS_EQUAL(22831, long(lmo.colours.size()));
  // can.ply is the same mesh scaled to metres and recentred: compare the extents.
  Vec3f a0 = lmo.vertices[0], a1 = a0, b0 = can.vertices[0], b1 = b0;
  for (const Vec3f& v : lmo.vertices) a0 = a0.cwiseMin(v), a1 = a1.cwiseMax(v);
  for (const Vec3f& v : can.vertices) b0 = b0.cwiseMin(v), b1 = b1.cwiseMax(v);
  CHECK(((a1 - a0) * 0.001f - (b1 - b0)).cwiseAbs().maxCoeff() < 1e-5f);
  DOUBLES_EQUAL(0.1937, b1.z() - b0.z(), 2e-4);  // README: 193.7 mm tall
  CHECK((lmo.triangles == can.triangles));
}
