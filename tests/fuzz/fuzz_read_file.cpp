// Fuzz target for one file reader, chosen at link time by kEdgefuseFuzzFormat (one executable
// per format, so each has its own corpus; CMakeLists.txt generates the one-line definition). The input is written to a file and read back through
// the reader's public function. Invariants (DEVELOPERS.md, bad input):
//   - no crash, no sanitizer report, no hang (libFuzzer's -timeout);
//   - a refusal names the file (the error starts with its path);
//   - a refusal leaves the caller's output as it was (no lost or half-written state);
//   - an accepted file gives a consistent result (sizes agree, indices in range, intrinsics valid).
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "edgefuse/hal/platform/config/config_toml.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/io/camera_toml.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/io/png.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "edgefuse/runtime/params.hpp"
#include "fuzz_check.hpp"

// The reader's format (see kReaders), defined by each program's generated fuzz_format_<name>.cpp.
extern const char kEdgefuseFuzzFormat[];

namespace {

using namespace edgefuse;
using namespace edgefuse::io;

// EDGEFUSE_FUZZ_VERBOSE=1: print each refusal (to see what a seed or a kept input does).
const bool g_verbose = std::getenv("EDGEFUSE_FUZZ_VERBOSE") != nullptr;

void check_refusal(const std::string& path, const std::string& err) {
  if (g_verbose) std::fprintf(stderr, "refused: %s\n", err.c_str());
  FUZZ_CHECK(err.compare(0, path.size(), path) == 0, "the refusal does not start with the file's path: '%s'",
             err.c_str());
}

template <class T>
bool same_size_or_empty(const std::vector<T>& v, size_t n) {
  return v.empty() || v.size() == n;
}

void check_cloud(const PointCloud& c) {
  FUZZ_CHECK(c.width >= 0 && c.height >= 1 && size_t(c.width) * size_t(c.height) == c.points.size(),
             "cloud %dx%d holds %zu points", c.width, c.height, c.points.size());
  FUZZ_CHECK(same_size_or_empty(c.normals, c.size()) && same_size_or_empty(c.colours, c.size()) &&
                 same_size_or_empty(c.labels, c.size()) && same_size_or_empty(c.support, c.size()),
             "per-point arrays disagree with %zu points", c.size());
}

// A cloud/mesh/list the reader must not touch when it refuses.
PointCloud sentinel_cloud() {
  PointCloud c;
  c.points.push_back(Vec3f(1, 2, 3));
  c.width = 1;
  return c;
}
bool is_sentinel(const PointCloud& c) {
  return c.points.size() == 1 && c.points[0] == Vec3f(1, 2, 3) && c.width == 1 && c.height == 1 && c.normals.empty();
}

void read_cloud(const std::string& path, bool (*read)(const std::string&, PointCloud&, std::string&)) {
  PointCloud c = sentinel_cloud();
  std::string err;
  if (read(path, c, err)) return check_cloud(c);
  check_refusal(path, err);
  FUZZ_CHECK(is_sentinel(c), "a refused cloud file changed the caller's cloud (%zu points)", c.size());
}
void read_pcd_file(const std::string& path) { read_cloud(path, read_pcd); }
void read_ply_cloud(const std::string& path) { read_cloud(path, read_ply); }

void read_ply_mesh(const std::string& path) {
  TriangleMesh m;
  m.vertices.push_back(Vec3f(1, 2, 3));
  std::string err;
  if (read_ply(path, m, err)) {
    FUZZ_CHECK(same_size_or_empty(m.normals, m.vertices.size()) && same_size_or_empty(m.colours, m.vertices.size()),
               "per-vertex arrays disagree with %zu vertices", m.vertices.size());
    for (const auto& t : m.triangles)
      for (uint32_t i : t) FUZZ_CHECK(i < m.vertices.size(), "triangle index %u of %zu vertices", i, m.vertices.size());
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(m.vertices.size() == 1 && m.triangles.empty(), "a refused PLY changed the caller's mesh");
}

void read_png16(const std::string& path) {
  std::vector<uint16_t> px(1, 7);
  int w = -5, h = -5;
  std::string err;
  if (read_png_u16(path, px, w, h, err)) {
    FUZZ_CHECK(w > 0 && h > 0 && px.size() == size_t(w) * size_t(h), "%dx%d image with %zu pixels", w, h, px.size());
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(px.size() == 1 && px[0] == 7 && w == -5 && h == -5, "a refused PNG changed the caller's image");
}

void read_png8(const std::string& path) {
  std::vector<Rgb8> px(1);
  px[0].r = 7;
  int w = -5, h = -5;
  std::string err;
  if (read_png_rgb8(path, px, w, h, err)) {
    FUZZ_CHECK(w > 0 && h > 0 && px.size() == size_t(w) * size_t(h), "%dx%d image with %zu pixels", w, h, px.size());
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(px.size() == 1 && px[0].r == 7 && w == -5 && h == -5, "a refused PNG changed the caller's image");
}

void read_camera(const std::string& path) {
  CameraToml cam;
  cam.intr.fx = 123.0f;
  std::string err;
  if (read_camera_toml(path, cam, err)) {
    FUZZ_CHECK(cam.intr.validate() == Status::kOk, "accepted intrinsics fail validate()");
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(cam.intr.fx == 123.0f, "a refused camera.toml changed the caller's intrinsics");
}

void read_rig(const std::string& path) {
  RigToml rig;
  rig.name = "sentinel";
  std::string err;
  if (read_rig_toml(path, rig, err)) {
    for (const RigSensor& s : rig.sensors)
      if (s.kind == SensorKind::kPinhole)
        FUZZ_CHECK(s.pinhole.validate() == Status::kOk, "sensor %s: accepted intrinsics fail validate()", s.name.c_str());
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(rig.name == "sentinel" && rig.sensors.empty(), "a refused rig.toml changed the caller's rig");
}

void read_board(const std::string& path) {
  BoardHal hal;
  hal.pins.emplace_back();
  std::string err;
  if (read_board_hal(path, hal, err)) return;
  check_refusal(path, err);
  FUZZ_CHECK(hal.pins.size() == 1 && hal.cameras.empty(), "a refused hal.toml changed the caller's board");
}

// A store must either take the whole file or stay as it was: a rejected edgefused.toml may not
// leave half of its values behind.
void read_config(const std::string& path) {
  static runtime::ParamStore store;  // ~20 KB: static, as on the board
  static runtime::ParamStore before;
  store = runtime::ParamStore();
  before = store;
  std::string err;
  const bool ok = hal::load_config_toml(path, store, err);
  char a[runtime::ParamStore::kTextCap], b[runtime::ParamStore::kTextCap], e[160];
  for (int id = 0; id < runtime::kParamCount; ++id) {
    store.format(id, a, sizeof a);
    if (ok) {  // every value the file set must be one set() accepts again
      runtime::ParamStore again;
      FUZZ_CHECK(again.set(id, a, e, sizeof e), "%s = %s was stored but does not parse again: %s",
                 runtime::kParamDefs[id].key, a, e);
    } else {
      before.format(id, b, sizeof b);
      FUZZ_CHECK(!std::strcmp(a, b), "a refused configuration changed %s from %s to %s", runtime::kParamDefs[id].key,
                 b, a);
    }
  }
  if (!ok) check_refusal(path, err);
}

template <class T, class Read>
void read_list(const std::string& path, Read read, const char* what) {
  std::vector<T> v(1);
  std::string err;
  if (read(path, v, err)) return;
  check_refusal(path, err);
  FUZZ_CHECK(v.size() == 1, "a refused %s changed the caller's list (%zu entries)", what, v.size());
}

void read_tum(const std::string& path) {
  read_list<StampedPose>(path, read_tum_trajectory, "trajectory");
}
void read_extrinsics(const std::string& path) {
  read_list<SensorExtrinsic>(path, read_extrinsics_txt, "extrinsics.txt");
}
void read_objects(const std::string& path) {
  read_list<ObjectPose>(path, read_objects_txt, "objects.txt");
}

void read_profiles(const std::string& path) {
  ProfileSet p;
  p.beams = 3;
  p.stamps_s.push_back(1.0);
  p.ranges_m.assign(3, 0.5f);
  std::string err;
  if (read_profiles_txt(path, 4, p, err)) {
    FUZZ_CHECK(p.beams == 4 && p.ranges_m.size() == p.size() * 4, "%zu profiles of 4 beams hold %zu ranges", p.size(),
               p.ranges_m.size());
    return;
  }
  check_refusal(path, err);
  FUZZ_CHECK(p.beams == 3 && p.size() == 1, "a refused profiles.txt changed the caller's profiles");
}

void read_pose_matrix(const std::string& path) {
  Pose T;
  T.t = Vec3f(1, 2, 3);
  std::string err;
  if (read_pose_matrix_txt(path, T, err)) return;
  check_refusal(path, err);
  FUZZ_CHECK(T.t == Vec3f(1, 2, 3), "a refused pose file changed the caller's pose");
}

struct Reader {
  const char* format;
  const char* file_name;  // the readers do not look at the extension, but a person reading a kept input does
  void (*run)(const std::string& path);
};

constexpr Reader kReaders[] = {
    {"pcd", "input.pcd", read_pcd_file},
    {"ply_cloud", "input.ply", read_ply_cloud},
    {"ply_mesh", "input.ply", read_ply_mesh},
    {"png16", "input.png", read_png16},
    {"png_rgb", "input.png", read_png8},
    {"camera_toml", "camera.toml", read_camera},
    {"rig_toml", "rig.toml", read_rig},
    {"hal_toml", "hal.toml", read_board},
    {"config_toml", "edgefused.toml", read_config},
    {"tum", "groundtruth.txt", read_tum},
    {"extrinsics", "extrinsics.txt", read_extrinsics},
    {"objects", "objects.txt", read_objects},
    {"profiles", "profiles.txt", read_profiles},
    {"pose_txt", "pose.txt", read_pose_matrix},
};

const Reader& reader() {
  for (const Reader& r : kReaders)
    if (!std::strcmp(r.format, kEdgefuseFuzzFormat)) return r;
  std::fprintf(stderr, "unknown fuzz format %s\n", kEdgefuseFuzzFormat);
  std::abort();
}

// One folder per process (libFuzzer's -jobs run several): /dev/shm keeps the writes off the disk.
std::string input_path() {
  const char* base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  char dir[256];
  std::snprintf(dir, sizeof dir, "%s/edgefuse-fuzz-%ld", base, long(getpid()));
  if (mkdir(dir, 0700) != 0 && errno != EEXIST) {
    std::fprintf(stderr, "cannot create %s\n", dir);
    std::abort();
  }
  return std::string(dir) + "/" + reader().file_name;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = input_path();
  FILE* f = std::fopen(path.c_str(), "wb");
  FUZZ_CHECK(f != nullptr, "cannot write %s", path.c_str());
  FUZZ_CHECK(std::fwrite(data, 1, size, f) == size && std::fclose(f) == 0, "cannot write %s", path.c_str());
  reader().run(path);
  return 0;
}
