// Steady state allocates nothing: integrate + raycast (float and fixed point) and point
// extraction are run with an allocation counter around them, which must read zero.
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 64;
VolumeStorage<kDim> g_storage;
SensorBuffers<float> g_sensor_float;
SensorBuffers<Fixed> g_sensor_fixed;
template <class Real>
SensorBuffers<Real>& sensor();
template <>
SensorBuffers<float>& sensor<float>() { return g_sensor_float; }
template <>
SensorBuffers<Fixed>& sensor<Fixed>() { return g_sensor_fixed; }
SurfacePoint g_points[200000];
}  // namespace

TEST_GROUP(AllocFree){};

template <class Real>
static void run_steady_state() {
  PinholeIntrinsics cam;
  cam.width = 160;
  cam.height = 120;
  cam.fx = cam.fy = 150;
  cam.cx = 79.5f;
  cam.cy = 59.5f;
  cam.depth_scale = 5000;
  TsdfVolume vol;
  CHECK(vol.init(g_storage.view(), kDim, Vec3f(-0.32f, -0.32f, 0.48f), TsdfParams::defaults_for(0.01f, 0.04f)) ==
        Status::kOk);
  Scene scene;
  scene.add_sphere(Vec3f(0, 0, 0.8f), 0.12f);
  scene.add_plane(Vec3f(0, 0, -1), 1.0f);
  // Setup (allowed to allocate): frames, ray norms, output maps.
  std::vector<Pose> poses = {look_at(Vec3f(0, 0, 0), Vec3f(0, 0, 0.8f)), look_at(Vec3f(0.05f, 0, 0), Vec3f(0, 0, 0.8f))};
  std::vector<std::vector<uint16_t>> depth(2);
  std::vector<std::vector<Rgb8>> colour(2);
  for (int i = 0; i < 2; ++i) render(scene, cam, poses[std::size_t(i)], depth[std::size_t(i)], &colour[std::size_t(i)]);
  const std::size_t pixels = std::size_t(cam.width) * cam.height;
  const ImageView<const Real> norms = sensor<Real>().ray_norms(cam);
  FrameScratch scratch = sensor<Real>().scratch();
  std::vector<float> d(pixels);
  std::vector<Vec3f> vtx(pixels), nrm(pixels);
  std::vector<Rgba8> col(pixels);
  const RaycastMaps maps{{d.data(), cam.width, cam.height}, {vtx.data(), cam.width, cam.height},
                         {nrm.data(), cam.width, cam.height}, {col.data(), cam.width, cam.height}};

  alloc_count_start();
  for (int round = 0; round < 3; ++round)
    for (int i = 0; i < 2; ++i) {
      const DepthFrame f{{depth[std::size_t(i)].data(), cam.width, cam.height},
                         {colour[std::size_t(i)].data(), cam.width, cam.height}};
      integrate<Real>(vol, cam, norms, f, poses[std::size_t(i)], scratch);
      raycast<Real>(vol, cam, poses[std::size_t(i)], maps);
    }
  std::size_t count = 0;
  extract_points(vol, g_points, sizeof(g_points) / sizeof(g_points[0]), count);
  const long allocations = alloc_count();
  CHECK(count > 1000);  // the work really ran
  LONGS_EQUAL(0, allocations);
}

TEST(AllocFree, FloatIntegrateRaycastExtractAllocateNothing) { run_steady_state<float>(); }
TEST(AllocFree, FixedIntegrateRaycastExtractAllocateNothing) { run_steady_state<Fixed>(); }

namespace {
std::vector<int>* volatile g_escape;  // keeps the compiler from eliding the allocations below
}

TEST(AllocFree, TheCounterSeesAllocations) {
  alloc_count_start();
  g_escape = new std::vector<int>(100);  // operator new twice: the vector and its storage
  const long n = alloc_count();
  delete g_escape;
  CHECK(n >= 2);
}
