// The unified depth-sequence reader on every real layout (TUM, 7-Scenes, rig set, single frame)
// and on broken folders; the rig set loaders (objects, extrinsics, line scans).
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/png.hpp"
#include "edgefuse/io/rig.hpp"
#include "formats_test_util.hpp"

using namespace edgefuse;
using namespace formats_test;

namespace {

const char* kCam = "width = 4\nheight = 3\nfx = 2\nfy = 2\ncx = 1.5\ncy = 1\ndepth_scale = 1000\n";

// A tiny TUM folder: 3 depth frames 4x3, rgb for two of them, ground truth for the first two.
void make_tum(const std::string& root) {
  std::filesystem::create_directories(root + "/depth");
  std::filesystem::create_directories(root + "/rgb");
  std::string err, list = "# depth maps\n", rgb = "# colour\n";
  const char* stamps[] = {"10.000000", "10.033000", "10.066000"};
  for (int i = 0; i < 3; ++i) {
    const std::string rel = std::string("depth/") + stamps[i] + ".png";
    CHECK(io::write_png_u16(root + "/" + rel, std::vector<uint16_t>(12, uint16_t(1000 + i)), 4, 3, err));
    list += std::string(stamps[i]) + " " + rel + "\n";
  }
  for (const char* s : {"10.005000", "10.060000"}) {
    const std::string rel = std::string("rgb/") + s + ".png";
    CHECK(io::write_png_rgb8(root + "/" + rel, std::vector<Rgb8>(12), 4, 3, err));
    rgb += std::string(s) + " " + rel + "\n";
  }
  write_bytes(root + "/depth.txt", list);
  write_bytes(root + "/rgb.txt", rgb);
  write_bytes(root + "/camera.toml", kCam);
  write_bytes(root + "/groundtruth.txt", "9.99 1 2 3 0 0 0 1\n10.035 4 5 6 0 0 0 1\n");
}

void expect_open_fails(const std::string& path, const std::string& sensor, const std::string& needle) {
  io::DepthSequence seq;
  std::string err;
  CHECK_FALSE_TEXT(io::open_depth_sequence(path, sensor, seq, err), ("expected failure: " + needle).c_str());
  CHECK_TEXT(err.find(needle) != std::string::npos, ("expected '" + needle + "' in: " + err).c_str());
}

}  // namespace

TEST_GROUP(FormatsDataset) {
  TempDir dir;
};

TEST(FormatsDataset, SyntheticTumFolder) {
  const std::string root = dir.file("tum");
  make_tum(root);
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kTum);
  LONGS_EQUAL(3, long(seq.frames.size()));
  CHECK(seq.colour_registered);
  // Nearest within 0.02 s: 10.000 -> 10.005, 10.066 -> 10.060; 10.033 has none that close.
  CHECK(seq.frames[0].colour_path.find("10.005000.png") != std::string::npos);
  CHECK(seq.frames[1].colour_path.empty());
  CHECK(seq.frames[2].colour_path.find("10.060000.png") != std::string::npos);
  // Poses: nearest within 0.02 s.
  CHECK(seq.frames[0].has_pose && seq.frames[1].has_pose && !seq.frames[2].has_pose);
  DOUBLES_EQUAL(1.0, seq.frames[0].T_world_cam.t.x(), 0);
  DOUBLES_EQUAL(4.0, seq.frames[1].T_world_cam.t.x(), 0);
  std::vector<uint16_t> d;
  CHECK_TEXT(io::load_depth(seq.frames[2], seq.intr, d, err), err.c_str());
  LONGS_EQUAL(1002, d[11]);
  std::vector<Rgb8> c;
  CHECK_TEXT(io::load_colour(seq.frames[0], seq.intr, c, err), err.c_str());
  CHECK_FALSE(io::load_colour(seq.frames[1], seq.intr, c, err));
  CHECK_FALSE(io::load_amplitude(seq.frames[0], seq.intr, d, err));
}

TEST(FormatsDataset, BrokenTumFolders) {
  const std::string root = dir.file("tum");
  make_tum(root);
  const std::string depth_txt = read_bytes(root + "/depth.txt");
  write_bytes(root + "/depth.txt", depth_txt + "10.1 depth/missing.png\n");
  expect_open_fails(root, "", "depth.txt:5: listed file " + root + "/depth/missing.png does not exist");
  write_bytes(root + "/depth.txt", depth_txt + "10.05 depth/10.000000.png\n");
  expect_open_fails(root, "", "depth.txt:5: timestamp 10.050000 is not after the previous 10.066000");
  write_bytes(root + "/depth.txt", depth_txt + "10.5\n");
  expect_open_fails(root, "", "depth.txt:5: expected 'timestamp path', got 1 value");
  write_bytes(root + "/depth.txt", garbage(3000, 7));
  expect_open_fails(root, "", root + "/depth.txt:");
  write_bytes(root + "/depth.txt", "# nothing\n");
  expect_open_fails(root, "", "depth.txt: lists no frames");
  write_bytes(root + "/depth.txt", depth_txt);
  write_bytes(root + "/rgb.txt", "10.0 rgb/nope.png\n");
  expect_open_fails(root, "", root + "/rgb.txt:1: listed file");
  std::filesystem::remove(root + "/rgb.txt");
  write_bytes(root + "/groundtruth.txt", "10.0 1 2 3 0 0 0\n");
  expect_open_fails(root, "", root + "/groundtruth.txt:1: expected 8 values");
  std::filesystem::remove(root + "/groundtruth.txt");
  write_bytes(root + "/camera.toml", std::string(kCam) + "fx = -3\n");
  expect_open_fails(root, "", root + "/camera.toml:");
  write_bytes(root + "/camera.toml", "width = 4\nheight = 3\nfx = -3\nfy = 2\ncx = 1.5\ncy = 1\ndepth_scale = 1000\n");
  expect_open_fails(root, "", root + "/camera.toml: key 'fx' (line 3) must be > 0, got -3");
  std::filesystem::remove(root + "/camera.toml");
  expect_open_fails(root, "", root + "/camera.toml: cannot open");
  expect_open_fails(root, "xtion", "sensor 'xtion' requested but the folder has no rig.toml");
}

TEST(FormatsDataset, LoadDepthChecksTheImage) {
  const std::string root = dir.file("tum");
  make_tum(root);
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  const std::string png = seq.frames[0].depth_path;
  std::vector<uint16_t> d;
  CHECK(io::write_png_u16(png, std::vector<uint16_t>(20, 1), 5, 4, err));
  CHECK_FAILS_NAMING(io::load_depth(seq.frames[0], seq.intr, d, err), err, png);
  CHECK_TEXT(err.find("image is 5x4 but the intrinsics say 4x3") != std::string::npos, err.c_str());
  CHECK(io::write_png_rgb8(png, std::vector<Rgb8>(12), 4, 3, err));
  CHECK_FAILS_NAMING(io::load_depth(seq.frames[0], seq.intr, d, err), err, png);
  write_bytes(png, "");
  CHECK_FAILS_NAMING(io::load_depth(seq.frames[0], seq.intr, d, err), err, png);
  std::filesystem::remove(png);
  CHECK_FAILS_NAMING(io::load_depth(seq.frames[0], seq.intr, d, err), err, png);
}

TEST(FormatsDataset, DetectionFailures) {
  expect_open_fails(dir.file("nope"), "", dir.file("nope") + ": no such folder");
  write_bytes(dir.file("file"), "x");
  expect_open_fails(dir.file("file"), "", dir.file("file") + ": not a folder");
  std::filesystem::create_directory(dir.file("empty"));
  expect_open_fails(dir.file("empty"), "", dir.file("empty") + ": not a depth sequence");
}

TEST(FormatsDataset, PerFrameAndSingleFrameFolders) {
  const std::string root = dir.file("frames");
  std::filesystem::create_directory(root);
  std::string err;
  for (const char* n : {"000000", "000002", "000001"}) {
    CHECK(io::write_png_u16(root + "/frame-" + n + ".depth.png", std::vector<uint16_t>(6, 800), 3, 2, err));
    write_bytes(root + "/frame-" + n + ".pose.txt", "1 0 0 0.5\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  }
  write_bytes(root + "/camera-intrinsics.txt", "585 0 1\n0 585 0.5\n0 0 1\n");
  io::DepthSequence seq;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kPerFrame);
  LONGS_EQUAL(3, long(seq.frames.size()));
  DOUBLES_EQUAL(2.0, seq.frames[2].stamp_s, 0);
  LONGS_EQUAL(3, seq.intr.width);  // from the first PNG: camera-intrinsics.txt has no size
  DOUBLES_EQUAL(1000.0, seq.intr.depth_scale, 0);
  CHECK(seq.frames[1].has_pose && !seq.colour_registered && seq.frames[1].colour_path.empty());
  // camera.toml must agree with camera-intrinsics.txt.
  write_bytes(root + "/camera.toml", "width = 3\nheight = 2\nfx = 580\nfy = 585\ncx = 1\ncy = 0.5\ndepth_scale = 1000\n");
  expect_open_fails(root, "", root + "/camera-intrinsics.txt: fx fy cx cy = 585 585 1 0.5 disagree with");
  std::filesystem::remove(root + "/camera.toml");
  write_bytes(root + "/frame-000001.pose.txt", "1 0 0\n");
  expect_open_fails(root, "", root + "/frame-000001.pose.txt: holds 3 numbers, expected 16");
  write_bytes(root + "/frame-000001.pose.txt", "1 0 0 0.5\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  CHECK(io::write_png_u16(root + "/frame-1.depth.png", std::vector<uint16_t>(6, 800), 3, 2, err));
  expect_open_fails(root, "", "frame-000001.depth.png and frame-1.depth.png have the same frame number");
  std::filesystem::remove(root + "/frame-1.depth.png");
  std::filesystem::remove(root + "/camera-intrinsics.txt");
  expect_open_fails(root, "", root + ": no camera.toml or camera-intrinsics.txt");

  const std::string one = dir.file("one");
  std::filesystem::create_directory(one);
  CHECK(io::write_png_u16(one + "/depth.png", std::vector<uint16_t>(12, 900), 4, 3, err));
  expect_open_fails(one, "", one + "/camera.toml: cannot open");
  write_bytes(one + "/camera.toml", kCam);
  CHECK_TEXT(io::open_depth_sequence(one, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kSingleFrame);
  LONGS_EQUAL(1, long(seq.frames.size()));
  CHECK(!seq.frames[0].has_pose && !seq.colour_registered);
}

TEST(FormatsDataset, BrokenRigSets) {
  const std::string root = dir.file("rig");
  make_tum(root + "/cam");
  std::filesystem::remove(root + "/cam/camera.toml");
  const std::string rig = "[[sensor]]\nname = \"cam\"\nkind = \"pinhole\"\nwidth = 4\nheight = 3\nfx = 2\nfy = 2\n"
                          "cx = 1\ncy = 1\ndepth_scale = 5000\ncolor = true\namplitude = true\n";
  write_bytes(root + "/rig.toml", rig);
  expect_open_fails(root, "", root + "/cam/amplitude.txt: cannot open");  // the rig promises amplitude
  write_bytes(root + "/rig.toml", rig + "[[sensor]]\nname = \"gone\"\nkind = \"pinhole\"\nwidth = 4\nheight = 3\n"
                                        "fx = 2\nfy = 2\ncx = 1\ncy = 1\ndepth_scale = 5000\n");
  expect_open_fails(root, "gone", root + "/gone: no such folder");
  expect_open_fails(root, "other", root + "/rig.toml: no sensor named 'other' (sensors: cam, gone)");
  write_bytes(root + "/rig.toml", "[[sensor]]\nname = \"cam\"\nkind = \"pinhole\"\n");
  expect_open_fails(root, "", root + "/rig.toml: sensor 'cam' (line 1): missing key 'width'");
  expect_open_fails(root + "/cam", "", root + "/rig.toml: sensor 'cam' (line 1): missing key 'width'");
  io::RigSet set;
  std::string err;
  write_bytes(root + "/rig.toml", rig + "[[object]]\nid = 1\nmodel = \"m.ply\"\n");
  write_bytes(root + "/objects.txt", "2 0 0 0 0 0 0 1\n");
  CHECK_FAILS_NAMING(io::open_rig_set(root, set, err), err, root + "/objects.txt");
  CHECK_TEXT(err.find("object id 2 has no [[object]]") != std::string::npos, err.c_str());
  write_bytes(root + "/objects.txt", "1 0 0 0 0 0 0 1\n");
  write_bytes(root + "/extrinsics.txt", "cam tof 0 0 0 0 0 0 1\n");
  CHECK_FAILS_NAMING(io::open_rig_set(root, set, err), err, root + "/extrinsics.txt");
  CHECK_TEXT(err.find("sensor 'tof' is not in") != std::string::npos, err.c_str());
  io::LineScan scan;
  CHECK_FALSE(io::open_line_scan(set.rig, "cam", scan, err));
}

TEST(FormatsDataset, RealTum) {
  const std::string root = edgefuse_test::require_data("tum_fr1_xyz_37");
  if (root.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kTum);
  LONGS_EQUAL(37, long(seq.frames.size()));
  DOUBLES_EQUAL(517.3, seq.intr.fx, 1e-4);
  DOUBLES_EQUAL(5000.0, seq.intr.depth_scale, 0);
  LONGS_EQUAL(5, long(seq.distortion.coeffs.size()));
  CHECK(seq.colour_registered);
  DOUBLES_EQUAL(1305031102.160407, seq.frames[0].stamp_s, 1e-6);
  CHECK(seq.frames[0].colour_path.find("rgb/1305031102.175304.png") != std::string::npos);
  for (const io::FrameRef& f : seq.frames) CHECK(f.has_pose && !f.colour_path.empty());
  std::vector<uint16_t> d;
  CHECK_TEXT(io::load_depth(seq.frames[0], seq.intr, d, err), err.c_str());
  std::vector<Rgb8> c;
  CHECK_TEXT(io::load_colour(seq.frames[36], seq.intr, c, err), err.c_str());
  // Ground truth starts at (1.3563, 0.6305, 1.6380) 3.5 s earlier; fr1_xyz moves a few cm.
  CHECK((seq.frames[0].T_world_cam.t - Vec3f(1.3563f, 0.6305f, 1.6380f)).norm() < 0.2f);
}

TEST(FormatsDataset, Real7Scenes) {
  const std::string root = edgefuse_test::require_data("7scenes_redkitchen_300");
  if (root.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kPerFrame);
  LONGS_EQUAL(300, long(seq.frames.size()));
  DOUBLES_EQUAL(299.0, seq.frames[299].stamp_s, 0);
  DOUBLES_EQUAL(585.0, seq.intr.fx, 0);
  DOUBLES_EQUAL(1000.0, seq.intr.depth_scale, 0);
  CHECK_FALSE(seq.colour_registered);
  for (const io::FrameRef& f : seq.frames) CHECK(f.has_pose && f.colour_path.empty());
  DOUBLES_EQUAL(-0.34045634, seq.frames[0].T_world_cam.t.x(), 1e-6);
  std::vector<uint16_t> d;
  CHECK_TEXT(io::load_depth(seq.frames[0], seq.intr, d, err), err.c_str());
  uint16_t lo = 65535, hi = 0;
  std::size_t valid = 0;
  for (uint16_t v : d)
    if (v) lo = std::min(lo, v), hi = std::max(hi, v), ++valid;
  LONGS_EQUAL(801, lo);  // README: frame 0 raw 801..3493 mm, 89 % valid
  LONGS_EQUAL(3493, hi);
  DOUBLES_EQUAL(0.89, double(valid) / double(d.size()), 0.01);
}

TEST(FormatsDataset, RealRigSet) {
  const std::string root = edgefuse_test::require_data("bin_rig_a");
  if (root.empty()) return;
  io::DepthSequence xtion, tof, direct;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", xtion, err), err.c_str());  // first pinhole sensor
  STRCMP_EQUAL("xtion", xtion.sensor_name.c_str());
  CHECK(xtion.layout == io::SequenceLayout::kRigSensor);
  LONGS_EQUAL(20, long(xtion.frames.size()));
  LONGS_EQUAL(320, xtion.intr.width);
  CHECK(xtion.colour_registered);
  DOUBLES_EQUAL(1003.8, xtion.frames[19].stamp_s, 1e-9);
  CHECK_TEXT(io::open_depth_sequence(root, "tof", tof, err), err.c_str());
  DOUBLES_EQUAL(88.95, tof.intr.fy, 1e-4);
  CHECK(!tof.colour_registered && !tof.frames[3].amplitude_path.empty());
  std::vector<uint16_t> amp, depth;
  CHECK_TEXT(io::load_amplitude(tof.frames[3], tof.intr, amp, err), err.c_str());
  CHECK_TEXT(io::load_depth(tof.frames[3], tof.intr, depth, err), err.c_str());
  LONGS_EQUAL(160 * 120, long(amp.size()));
  CHECK_TEXT(io::open_depth_sequence(root + "/xtion", "", direct, err), err.c_str());  // intrinsics from ../rig.toml
  CHECK(direct.layout == io::SequenceLayout::kRigSensor);
  LONGS_EQUAL(20, long(direct.frames.size()));
  expect_open_fails(root, "laser", "sensor 'laser' is a line_scanner");
  expect_open_fails(root, "kinect", "no sensor named 'kinect' (sensors: xtion, tof, laser)");

  // README: T_world_tof = T_world_xtion * T_xtion_tof exactly, for every frame.
  io::RigSet set;
  CHECK_TEXT(io::open_rig_set(root, set, err), err.c_str());
  LONGS_EQUAL(6, long(set.objects.size()));
  LONGS_EQUAL(1, long(set.extrinsics.size()));
  for (std::size_t i = 0; i < 20; ++i) {
    const Pose predicted = xtion.frames[i].T_world_cam * set.extrinsics[0].T_a_b;
    CHECK((predicted.matrix() - tof.frames[i].T_world_cam.matrix()).cwiseAbs().maxCoeff() < 2e-5f);
  }

  // The laser: 300 profiles of 640 beams; every return lies in the bin (README geometry), which
  // checks the beam-angle convention and the pose lookup together.
  io::LineScan scan;
  CHECK_TEXT(io::open_line_scan(set.rig, "laser", scan, err), err.c_str());
  LONGS_EQUAL(300, long(scan.profiles.size()));
  LONGS_EQUAL(640, scan.profiles.beams);
  DOUBLES_EQUAL(1004.8 + 2.99, scan.profiles.stamps_s[299], 1e-6);
  std::size_t valid = 0, outside = 0;
  for (std::size_t p = 0; p < scan.profiles.size(); ++p) {
    CHECK(scan.has_pose[p]);
    for (int i = 0; i < 640; ++i) {
      const float r = scan.profiles.profile(p)[i];
      if (r == 0) continue;
      ++valid;
      const Vec3f w = scan.T_world_sensor[p] * (scan.sensor.line.beam_direction(i) * r);
      outside += !(std::fabs(w.x()) < 0.21f && std::fabs(w.y()) < 0.16f && w.z() > -0.011f && w.z() < 0.171f);
    }
  }
  DOUBLES_EQUAL(0.769, double(valid) / (300.0 * 640.0), 0.002);  // README: 0.769 valid
  LONGS_EQUAL(0, long(outside));
}

TEST(FormatsDataset, RealSingleFrame) {
  const std::string root = edgefuse_test::require_data("lmo_can_frame");
  if (root.empty()) return;
  io::DepthSequence seq;
  std::string err;
  CHECK_TEXT(io::open_depth_sequence(root, "", seq, err), err.c_str());
  CHECK(seq.layout == io::SequenceLayout::kSingleFrame);
  LONGS_EQUAL(1, long(seq.frames.size()));
  CHECK(!seq.frames[0].has_pose && seq.colour_registered);
  std::vector<uint16_t> d;
  CHECK_TEXT(io::load_depth(seq.frames[0], seq.intr, d, err), err.c_str());
  uint16_t lo = 65535, hi = 0;
  for (uint16_t v : d)
    if (v) lo = std::min(lo, v), hi = std::max(hi, v);
  LONGS_EQUAL(878, lo);  // README: 878..1804 mm
  LONGS_EQUAL(1804, hi);
  std::vector<Rgb8> c;
  CHECK_TEXT(io::load_colour(seq.frames[0], seq.intr, c, err), err.c_str());
}
