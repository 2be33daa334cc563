// Colour transfer onto geometry only another sensor measured (paint pass), points never seen in
// colour left uncoloured, and per-sensor trust from the noise models scaling the update weight.
#include <cmath>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/sensor/noise_model.hpp"
#include "edgefuse/tsdf/colour_pass.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse_test;

namespace {
constexpr int kDim = 64;
constexpr float kVoxel = 0.01f;
VolumeStorage<kDim> g_storage;
SensorBuffers<float> g_rgbd, g_tof;
float g_depth_m[320 * 240];
Vec3f g_vertex[320 * 240], g_normal[320 * 240];
Rgba8 g_colour[320 * 240];
uint16_t g_depth_scratch[320 * 240];
uint8_t g_trust[320 * 240];
SurfacePoint g_points[200000];

PinholeIntrinsics cam(int w, int h, float f) {
  PinholeIntrinsics c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = 0.5f * float(w) - 0.5f;
  c.cy = 0.5f * float(h) - 0.5f;
  c.depth_scale = 10000.0f;
  c.min_range_m = 0.1f;
  c.max_range_m = 3.0f;
  return c;
}

bool near_box(const Vec3f& p, const Vec3f& centre, const Vec3f& half) {
  return (p - centre).cwiseAbs().maxCoeff() <= half.maxCoeff() + 0.005f && std::fabs(p.x() - centre.x()) <= half.x() + 0.005f &&
         std::fabs(p.y() - centre.y()) <= half.y() + 0.005f && std::fabs(p.z() - centre.z()) <= half.z() + 0.005f;
}
}  // namespace

TEST_GROUP(FusionColour){};

// The RGB-D camera's depth misses the box (a dark part); the ToF camera measures it. After the
// paint pass the box points carry the box's colour; the part of the wall that no colour image
// sees stays uncoloured (alpha 0).
TEST(FusionColour, ColourTransferOntoTofOnlyGeometry) {
  const Vec3f box_c(0.0f, 0.0f, 0.85f), box_h(0.06f, 0.05f, 0.04f);
  Scene scene;
  scene.add_box(box_c, box_h, Pose(), Rgb8{30, 60, 220});
  scene.add_plane(Vec3f(0, 0, -1), 1.0f, Rgb8{200, 200, 200});  // wall at z = 1
  TsdfVolume vol;
  CHECK(vol.init(g_storage.view(true), kDim, Vec3f(-0.32f, -0.32f, 0.5f), TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) ==
        Status::kOk);
  const PinholeIntrinsics rgbd = cam(320, 240, 600.0f);  // narrow: sees the box and some wall
  const PinholeIntrinsics tof = cam(160, 120, 100.0f);   // wide: sees the box and much more wall
  const Pose T_rgbd = Pose::identity();
  Pose T_tof;
  T_tof.t = Vec3f(0.03f, 0.0f, 0.0f);

  std::vector<uint16_t> depth;
  std::vector<Rgb8> colour;
  std::vector<int> item;
  render(scene, rgbd, T_rgbd, depth, &colour, nullptr, &item);
  for (std::size_t i = 0; i < depth.size(); ++i)
    if (item[i] == 0) depth[i] = 0;  // no structured-light depth on the box
  FrameScratch s_rgbd = g_rgbd.scratch(), s_tof = g_tof.scratch();
  CHECK(integrate<float>(vol, rgbd, g_rgbd.ray_norms(rgbd),
                         DepthFrame{ImageView<const uint16_t>(depth.data(), 320, 240),
                                    ImageView<const Rgb8>(colour.data(), 320, 240)},
                         T_rgbd, s_rgbd) == Status::kOk);
  std::vector<uint16_t> tdepth;
  render(scene, tof, T_tof, tdepth);
  // The ToF push with its per-pixel trust map (noise model) allocates nothing.
  const ImageView<const float> tof_norms = g_tof.ray_norms(tof);
  DepthFrame tf{ImageView<const uint16_t>(tdepth.data(), 160, 120), {}};
  tf.trust = ImageView<const uint8_t>(g_trust, 160, 120);
  alloc_count_start();
  CHECK(build_trust_map(NoiseModel::time_of_flight(), 0.005f, tf.depth, tof.depth_scale, {},
                        ImageView<uint8_t>(g_trust, 160, 120)) == Status::kOk);
  CHECK(integrate<float>(vol, tof, tof_norms, tf, T_tof, s_tof) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());

  auto box_colour_share = [&](int& box_points, int& box_coloured, int& far_wall, int& far_wall_coloured) {
    std::size_t n = 0;
    extract_points(vol, g_points, 200000, n);
    box_points = box_coloured = far_wall = far_wall_coloured = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const SurfacePoint& p = g_points[i];
      if (near_box(p.position, box_c, box_h) && p.position.z() < box_c.z() - box_h.z() + 0.004f) {
        ++box_points;
        if (p.colour.a != 0 && p.colour.b > 150 && p.colour.r < 100) ++box_coloured;
      }
      // wall outside the RGB-D view (|x| < 0.267 z, |y| < 0.2 z) but inside the ToF view and the space
      if ((std::fabs(p.position.x()) > 0.28f || std::fabs(p.position.y()) > 0.21f) && p.position.z() > 0.99f) {
        ++far_wall;
        far_wall_coloured += p.colour.a != 0;
      }
    }
  };
  int box_points, box_coloured, far_wall, far_wall_coloured;
  box_colour_share(box_points, box_coloured, far_wall, far_wall_coloured);
  CHECK(box_points > 50);
  CHECK(box_coloured < box_points / 10);  // before the paint pass: the box front is uncoloured

  RaycastMaps maps;
  maps.depth_m = ImageView<float>(g_depth_m, 320, 240);
  maps.vertex = ImageView<Vec3f>(g_vertex, 320, 240);
  maps.normal = ImageView<Vec3f>(g_normal, 320, 240);
  maps.colour = ImageView<Rgba8>(g_colour, 320, 240);
  alloc_count_start();
  CHECK(paint_colour<float>(vol, rgbd, g_rgbd.ray_norms(rgbd), ImageView<const Rgb8>(colour.data(), 320, 240), T_rgbd,
                            maps, s_rgbd, ImageView<uint16_t>(g_depth_scratch, 320, 240)) == Status::kOk);
  LONGS_EQUAL(0, alloc_count());
  box_colour_share(box_points, box_coloured, far_wall, far_wall_coloured);
  std::printf("\n  paint pass: %d of %d box points coloured; %d of %d wall points outside the colour view coloured\n",
              box_coloured, box_points, far_wall_coloured, far_wall);
  CHECK(box_coloured > box_points * 8 / 10);
  CHECK(far_wall > 50);
  LONGS_EQUAL(0, far_wall_coloured);
}

// The noise models: structured light grows with z^2 (Nguyen et al.), ToF with z / sqrt(amplitude).
TEST(FusionColour, NoiseModels) {
  const NoiseModel sl = NoiseModel::structured_light();
  DOUBLES_EQUAL(0.001371, sl.sigma_m(0.7f), 1e-6);
  DOUBLES_EQUAL(0.0012 + 0.0019 * 1.21, sl.sigma_m(1.5f), 1e-6);
  const NoiseModel tof = NoiseModel::time_of_flight();
  DOUBLES_EQUAL(0.005 * 0.7 / std::sqrt(0.25), tof.sigma_m(0.7f, 5000.0f), 1e-6);
  DOUBLES_EQUAL(0.02, tof.sigma_m(0.7f, 10.0f), 1e-6);  // capped
  DOUBLES_EQUAL(1.0, NoiseModel::constant(2e-5f).trust(0.001f, 0.2f), 1e-6);
  CHECK(sl.trust(0.001f, 1.5f) < sl.trust(0.001f, 0.7f));
  // trust map: 0 without depth, >= 1 with depth
  uint16_t d[4] = {0, 3500, 7500, 15000};
  uint16_t a[4] = {0, 20000, 20000, 100};
  CHECK(build_trust_map(tof, 0.001f, ImageView<const uint16_t>(d, 4, 1), 5000.0f, ImageView<const uint16_t>(a, 4, 1),
                        ImageView<uint8_t>(g_trust, 4, 1)) == Status::kOk);
  LONGS_EQUAL(0, g_trust[0]);
  CHECK(g_trust[1] > g_trust[2]);
  CHECK(g_trust[3] >= 1);
  CHECK(build_trust_map(tof, 0.0f, ImageView<const uint16_t>(d, 4, 1), 5000.0f, {}, ImageView<uint8_t>(g_trust, 4, 1)) ==
        Status::kInvalidArgument);
}

// Noise gate (`fuse --sensors --max-sigma`, default trunc / 2): a pixel whose modelled noise exceeds
// the gate gets trust 0 (no sample); the others keep their trust; a negative gate is refused.
TEST(FusionColour, NoiseGateDropsNoisyPixels) {
  const NoiseModel tof = NoiseModel::time_of_flight();
  // sigma: 0.7 m at a_n 1 -> 3.5 mm; 1.5 m at a_n 1 -> 7.5 mm; 0.7 m at a_n 0.005 -> 20 mm (cap)
  uint16_t d[4] = {0, 3500, 7500, 3500};
  uint16_t a[4] = {0, 20000, 20000, 100};
  uint8_t open[4], gated[4];
  CHECK(build_trust_map(tof, 0.001f, ImageView<const uint16_t>(d, 4, 1), 5000.0f, ImageView<const uint16_t>(a, 4, 1),
                        ImageView<uint8_t>(open, 4, 1)) == Status::kOk);
  CHECK(build_trust_map(tof, 0.001f, ImageView<const uint16_t>(d, 4, 1), 5000.0f, ImageView<const uint16_t>(a, 4, 1),
                        ImageView<uint8_t>(gated, 4, 1), 0.004f) == Status::kOk);
  LONGS_EQUAL(0, gated[0]);
  LONGS_EQUAL(open[1], gated[1]);  // 3.5 mm <= 4 mm: kept as it was
  LONGS_EQUAL(0, gated[2]);        // 7.5 mm
  LONGS_EQUAL(0, gated[3]);        // 20 mm
  CHECK(open[2] >= 1 && open[3] >= 1);
  CHECK(build_trust_map(tof, 0.001f, ImageView<const uint16_t>(d, 4, 1), 5000.0f, {}, ImageView<uint8_t>(gated, 4, 1),
                        -0.001f) == Status::kInvalidArgument);
}

// A trusted and a distrusted sensor disagree by 2 cm on a wall: the fused surface lies close to
// the trusted one. Trust 1/4 -> 2 of 8 weight units per sample: 2/10 of the way. A sub-unit sample
// (trust 1/255) fills an empty voxel at one unit but is skipped where a full sample exists.
TEST(FusionColour, TrustScalesTheWeight) {
  TsdfVolume vol;
  const PinholeIntrinsics c = cam(160, 120, 150.0f);
  Scene near_wall, far_wall;
  near_wall.add_plane(Vec3f(0, 0, -1), 0.80f);
  far_wall.add_plane(Vec3f(0, 0, -1), 0.82f);
  std::vector<uint16_t> d1, d2;
  render(near_wall, c, Pose(), d1);
  render(far_wall, c, Pose(), d2);
  std::vector<uint8_t> quarter(d2.size(), 64), tiny(d2.size(), 1);
  FrameScratch s = g_tof.scratch();
  const ImageView<const float> norms = g_tof.ray_norms(c);
  RaycastMaps maps;
  maps.depth_m = ImageView<float>(g_depth_m, 160, 120);
  auto fused_z = [&](const std::vector<uint8_t>* trust_far, bool near_first) {
    CHECK(vol.init(g_storage.view(false), kDim, Vec3f(-0.32f, -0.32f, 0.5f),
                   TsdfParams::defaults_for(kVoxel, 4 * kVoxel)) == Status::kOk);
    DepthFrame f1{ImageView<const uint16_t>(d1.data(), 160, 120), {}};
    DepthFrame f2{ImageView<const uint16_t>(d2.data(), 160, 120), {}};
    if (trust_far != nullptr) f2.trust = ImageView<const uint8_t>(trust_far->data(), 160, 120);
    if (near_first) CHECK(integrate<float>(vol, c, norms, f1, Pose(), s) == Status::kOk);
    CHECK(integrate<float>(vol, c, norms, f2, Pose(), s) == Status::kOk);
    CHECK(raycast<float>(vol, c, Pose(), maps) == Status::kOk);
    return maps.depth_m.at(80, 60);
  };
  const float z_equal = fused_z(nullptr, true);
  const float z_quarter = fused_z(&quarter, true);
  const float z_tiny = fused_z(&tiny, true);
  const float z_alone = fused_z(&tiny, false);
  std::printf("\n  0.800 m (trust 1) + 0.820 m (trust 1 / 0.25 / 1/255): %.4f / %.4f / %.4f m; 1/255 alone %.4f m\n",
              z_equal, z_quarter, z_tiny, z_alone);
  DOUBLES_EQUAL(0.81, z_equal, 0.001);
  DOUBLES_EQUAL(0.80 + 0.02 * 2.0 / 10.0, z_quarter, 0.001);
  DOUBLES_EQUAL(0.80, z_tiny, 0.0005);
  DOUBLES_EQUAL(0.82, z_alone, 0.0005);
}
