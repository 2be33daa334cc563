// Writes the seed corpus of the fuzz targets: small valid inputs of every format, made with the
// project's own writers (so a seed is what the product writes) or written out here where the
// product only reads the format. The fuzzer mutates these; ctest replays them.
//
//   fuzz_make_seeds SOURCE_DIR OUT_DIR     (SOURCE_DIR: the repository, for board/host-sim's files)
// The committed corpus came from `build/host/tests/fuzz/fuzz_make_seeds . tests/fuzz/corpus`.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "edgefuse/io/camera_toml.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/io/png.hpp"
#include "edgefuse/link/messages.hpp"
#include "edgefuse/link/robot_codec.hpp"
#include "edgefuse/runtime/calibration.hpp"

namespace fs = std::filesystem;
using namespace edgefuse;
using namespace edgefuse::io;

namespace {

std::string g_out;
bool g_ok = true;

std::string dir(const char* target) {
  const std::string d = g_out + "/" + target;
  fs::create_directories(d);
  return d;
}

void check(bool ok, const std::string& what, const std::string& err) {
  if (!ok) {
    std::fprintf(stderr, "%s: %s\n", what.c_str(), err.c_str());
    g_ok = false;
  }
}

void text(const char* target, const char* name, const std::string& body) {
  std::ofstream(dir(target) + "/" + name, std::ios::binary) << body;
}

void bytes(const char* target, const char* name, const uint8_t* p, size_t n) {
  std::ofstream(dir(target) + "/" + name, std::ios::binary).write(reinterpret_cast<const char*>(p), std::streamsize(n));
}

void copy(const char* target, const char* name, const std::string& from) {
  std::ifstream in(from, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  check(in.good() && s.str().size() > 0, from, "cannot read");
  text(target, name, s.str());
}

PointCloud small_cloud(bool organised) {
  PointCloud c;
  for (int i = 0; i < 4; ++i) {
    c.points.push_back(Vec3f(0.1f * i, -0.05f * i, 0.6f + 0.01f * i));
    c.normals.push_back(Vec3f(0, 0, -1));
    c.colours.push_back(Rgba8{uint8_t(40 * i), 100, 200, 255});
    c.support.push_back(uint8_t(3 + i));
  }
  c.width = organised ? 2 : 4;
  c.height = organised ? 2 : 1;
  return c;
}

void clouds() {
  std::string err;
  const PointCloud flat = small_cloud(false), grid = small_cloud(true);
  check(write_pcd(dir("pcd") + "/binary.pcd", flat, err, PcdEncoding::kBinary), "pcd", err);
  check(write_pcd(dir("pcd") + "/ascii.pcd", flat, err, PcdEncoding::kAscii), "pcd", err);
  check(write_pcd(dir("pcd") + "/compressed.pcd", flat, err, PcdEncoding::kBinaryCompressed), "pcd", err);
  check(write_pcd(dir("pcd") + "/organised.pcd", grid, err, PcdEncoding::kBinaryCompressed), "pcd", err);
  check(write_ply(dir("ply_cloud") + "/binary.ply", flat, err, PlyEncoding::kBinaryLittleEndian), "ply", err);
  check(write_ply(dir("ply_cloud") + "/ascii.ply", flat, err, PlyEncoding::kAscii), "ply", err);

  TriangleMesh m;  // a tetrahedron
  m.vertices = {Vec3f(0, 0, 0), Vec3f(0.1f, 0, 0), Vec3f(0, 0.1f, 0), Vec3f(0, 0, 0.1f)};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  check(write_ply(dir("ply_mesh") + "/binary.ply", m, err, PlyEncoding::kBinaryLittleEndian), "mesh", err);
  check(write_ply(dir("ply_mesh") + "/ascii.ply", m, err, PlyEncoding::kAscii), "mesh", err);
  m.normals.assign(4, Vec3f(0, 0, 1));
  m.colours.assign(4, Rgba8{10, 20, 30, 255});
  check(write_ply(dir("ply_mesh") + "/attributes.ply", m, err, PlyEncoding::kBinaryLittleEndian), "mesh", err);
  // A cloud reader reads a mesh file's vertices too.
  check(write_ply(dir("ply_cloud") + "/mesh.ply", m, err, PlyEncoding::kAscii), "mesh", err);
}

void images() {
  std::string err;
  std::vector<uint16_t> depth(4 * 3);
  for (size_t i = 0; i < depth.size(); ++i) depth[i] = uint16_t(i == 5 ? 0 : 3000 + 7 * i);
  check(write_png_u16(dir("png16") + "/depth.png", depth, 4, 3, err), "png16", err);
  std::vector<Rgb8> rgb(4 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = Rgb8{uint8_t(20 * i), uint8_t(255 - 20 * i), 128};
  check(write_png_rgb8(dir("png_rgb") + "/colour.png", rgb, 4, 3, err), "png_rgb", err);
  // Each reader also gets the other's image (a colour PNG where depth is expected, and back).
  check(write_png_rgb8(dir("png16") + "/colour.png", rgb, 4, 3, err), "png16", err);
  check(write_png_u16(dir("png_rgb") + "/depth.png", depth, 4, 3, err), "png_rgb", err);
}

void tomls(const std::string& src) {
  std::string err;
  CameraToml cam;
  cam.intr.width = 320;
  cam.intr.height = 240;
  cam.intr.fx = cam.intr.fy = 288.6f;
  cam.intr.cx = 159.5f;
  cam.intr.cy = 119.5f;
  cam.distortion.coeffs = {0.01, -0.002, 0, 0, 0};
  check(write_camera_toml(dir("camera_toml") + "/camera.toml", cam, err), "camera_toml", err);
  text("rig_toml", "rig.toml",
       "name = \"fuzz\"\n\n[[sensor]]\nname = \"xtion\"\nkind = \"pinhole\"\nwidth = 320\nheight = 240\n"
       "fx = 288.6\nfy = 288.6\ncx = 159.5\ncy = 119.5\ndepth_scale = 5000.0\nmin_range = 0.4\nmax_range = 3.5\n"
       "color = true\namplitude = false\n\n[[sensor]]\nname = \"laser\"\nkind = \"line_scanner\"\nbeams = 640\n"
       "fov_deg = 20.0\nmin_range = 0.05\nmax_range = 0.265\n\n[[object]]\nid = 1\nmodel = \"models/can.ply\"\n");
  copy("hal_toml", "host-sim.toml", src + "/board/host-sim/hal.toml");
  copy("config_toml", "host-sim.toml", src + "/board/host-sim/edgefused.toml");
}

void text_lists() {
  text("tum", "groundtruth.txt",
       "# timestamp tx ty tz qx qy qz qw\n1305031102.1758 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n"
       "1305031102.1858 1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n");
  text("extrinsics", "extrinsics.txt", "xtion tof 0.0573 0.0073 -0.0006 -0.0134 -0.0187 0.0190 0.9996\n");
  text("objects", "objects.txt",
       "1 -0.0382 -0.0107 0.0669 -0.5311 -0.6375 -0.2333 0.5071\n2 0.1106 0.0035 0.0237 -0.0709 0.1134 -0.6590 0.7402\n");
  text("profiles", "profiles.txt", "# stamp r0 r1 r2 r3\n0.000 0.20 0.21 0.22 0.23\n0.033 0.20 0 0.22 0.2301\n");
  text("pose_txt", "frame-000000.pose.txt",
       "1 0 0 0.1\n0 0.8 -0.6 0.2\n0 0.6 0.8 0.3\n0 0 0 1\n");
}

void link_frames() {
  static link::FrameWriter w;
  size_t n = 0;
  const uint8_t* f = w.encode(link::make_heartbeat(7, 123456789), n);
  check(f != nullptr, "link", "heartbeat does not encode");
  if (f) bytes("link", "heartbeat.bin", f, n);
  link::Message r = link::make_result(8, 223456789);
  Pose T;
  T.t = Vec3f(0.1f, -0.2f, 0.05f);
  link::add_object(r.body.result, 1, T, 0.9f, Vec3f(0.1f, -0.2f, 0.1f), Vec3f(0, 0, -1));
  link::add_object(r.body.result, 3, T, 0.7f, Vec3f(0.1f, -0.2f, 0.1f), Vec3f(0, 0, -1));
  f = w.encode(r, n);
  check(f != nullptr, "link", "result does not encode");
  if (f) bytes("link", "result.bin", f, n);
}

// The robot's requests: a text session, and protobuf request frames with clock ticks between them
// (fuzz_robot_request.cpp: 0xFF 0xFF n advances the clock by n ticks of 20 ms).
void robot_requests() {
  text("text_profile", "cycle.txt",
       "CAPTURE 0.4 0 0.6 0 0 0 1\nPOSE 0.4,0,0.6,0,0,0,1\nDETECT\nNEXT\nPICKED OK\nNEXT\nPICKED FAILED\nNEXT\n"
       "STATUS\nDETECT_ASYNC\nDETECT_STATUS\nSTOP\n");
  text("text_profile", "formats.txt",
       "UNITS mm\nROTATION kuka_abc\nCAPTURE 400 0 600 90 0 180\nROTATION axisangle\nPOSE 400 0 600 0 3.14159 0\n"
       "ROTATION wxyz\nHANDEYE ADD 400 0 600 1 0 0 0\nHANDEYE SOLVE\nHANDEYE SAVE\nHANDEYE RESET\nCALIBRATION\n");
  text("text_profile", "garbage.txt", "CAPTURE 1 2\nPICKED MAYBE\nJUMP\n\x01\x02\r\nNEXT 1,,2\nUNITS inch\n");
  static link::FrameWriter w;
  static link::Message m;
  std::string cycle;
  const robot::Command commands[] = {robot::Command::kCapture, robot::Command::kPose, robot::Command::kDetect,
                                     robot::Command::kNext, robot::Command::kPickResult, robot::Command::kStatus,
                                     robot::Command::kDetectAsync, robot::Command::kDetectStatus,
                                     robot::Command::kHandEyeAdd, robot::Command::kHandEyeSolve,
                                     robot::Command::kCalibrationGet, robot::Command::kUnknown, robot::Command::kStop};
  uint32_t id = 1;
  for (robot::Command c : commands) {
    robot::Request r;
    r.id = id++;
    r.command = c;
    r.has_pose = c == robot::Command::kCapture || c == robot::Command::kPose || c == robot::Command::kHandEyeAdd;
    r.T_base_flange = Pose::from_tq(0.4f, 0.0f, 0.6f, 0.0f, 0.0f, 0.0f, 1.0f);
    r.picked = true;
    link::request_message(r, m);
    size_t n = 0;
    const uint8_t* f = w.encode(m, n);
    check(f != nullptr, "robot_request", "a request does not encode");
    if (f == nullptr) return;
    cycle.append(reinterpret_cast<const char*>(f), n);
    if (c == robot::Command::kCapture || c == robot::Command::kDetect) cycle += std::string("\xff\xff\x0a", 3);
    if (c == robot::Command::kPose)
      bytes("robot_request", "pose.bin", f, n);
  }
  text("robot_request", "cycle.bin", cycle);
}

void calib_slot() {
  runtime::CalibrationData d;
  runtime::CalibPose p;
  p.tq[0] = 0.057f;
  runtime::calib_set_pair(d, "xtion", "tof", p);
  d.intrinsic_count = 1;
  std::snprintf(d.intrinsics[0].sensor, sizeof d.intrinsics[0].sensor, "tof");
  d.intrinsics[0].fx = 80.0f;
  d.intrinsics[0].fy = 88.95f;
  d.intrinsics[0].cx = 79.5f;
  d.intrinsics[0].cy = 59.5f;
  std::vector<uint8_t> image(runtime::calib_image_size());
  const size_t n = runtime::calib_encode(d, 3, image.data(), image.size());
  check(n > 0, "calib", "does not encode");
  bytes("calib", "slot.bin", image.data(), n);
}

void console_scripts() {
  // 0xFF ends a chunk; the byte after it is the number of 20 ms ticks that pass (fuzz_console.cpp).
  text("console", "help.txt", "help\r\nversion\r\nstatus\r\n");
  text("console", "params.txt", "param get\nparam get link.port\nparam set log.level 3\nparam set link.port 0\n");
  text("console", "scan.txt", std::string("scan start\n\xff\x60status\n\xff\xc8localize\n\xff\x10status\nscan stop\n", 44));
  text("console", "calib.txt",
       "calib set xtion 0.1 0 0 0 0 0 1\ncalib intrinsics tof 80 88.9 79.5 59.5\ncalib show\ncalib save\n"
       "calib reset\ncalib load\ncalib fuse xtion tof\n");
  text("console", "garbage.txt", std::string("sta\x08\x08tus\n\x01\x02\nmodel list\n\x03log debug\r\n", 36));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s SOURCE_DIR OUT_DIR\n", argv[0]);
    return 2;
  }
  g_out = argv[2];
  clouds();
  images();
  tomls(argv[1]);
  text_lists();
  link_frames();
  robot_requests();
  calib_slot();
  console_scripts();
  std::printf("seeds written to %s%s\n", argv[2], g_ok ? "" : " (with errors above)");
  return g_ok ? 0 : 1;
}
