// `edgefuse render` (tools/edgefuse/render.hpp): a plane of points seen head-on, a box in front of it
// drawn in its object colour, a box behind it hidden, the background around them.
#include <string>
#include <vector>

#include "render.hpp"
#include "test_support.hpp"  // CppUTest last

using namespace edgefuse;
using edgefuse::cli::RenderImage;
using edgefuse::cli::RenderObject;
using edgefuse::cli::RenderOptions;

namespace {

// A 20 x 20 cm plane at z = 1 m, 2 mm apart, normals towards the viewer at the origin.
io::PointCloud plane_cloud() {
  io::PointCloud c;
  for (int y = -50; y <= 50; ++y)
    for (int x = -50; x <= 50; ++x) {
      c.points.emplace_back(0.002f * float(x), 0.002f * float(y), 1.0f);
      c.normals.emplace_back(0.0f, 0.0f, -1.0f);
    }
  c.width = int(c.points.size());
  return c;
}

// An axis-aligned cube of edge `edge_m` centred on the model origin.
io::TriangleMesh cube(float edge_m) {
  io::TriangleMesh m;
  const float h = edge_m / 2;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h);
  const uint32_t faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : faces) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

bool same(Rgb8 a, Rgb8 b) { return a.r == b.r && a.g == b.g && a.b == b.b; }

}  // namespace

TEST_GROUP(Render){};

TEST(Render, ObjectInFrontIsDrawnBehindIsHidden) {
  const io::PointCloud cloud = plane_cloud();
  const io::TriangleMesh box = cube(0.04f);
  std::vector<RenderObject> objects(2);
  objects[0].mesh = &box;
  objects[0].T_world_object.t = Vec3f(0.0f, 0.0f, 0.97f);   // in front of the plane
  objects[1].mesh = &box;
  objects[1].T_world_object.t = Vec3f(0.06f, 0.06f, 1.05f);  // behind it
  RenderOptions o;
  o.width_px = 200;
  o.tilt_deg = 0;
  o.point_px = 2;
  RenderImage img;
  std::string err;
  CHECK_TRUE_TEXT(cli::render_scene(cloud, objects, o, img, err), err.c_str());
  // Head-on: 0.2 m over 200 - 2 x 8 px, the plane's centre at pixel (100, 100).
  LONGS_EQUAL(200, img.width);
  LONGS_EQUAL(200, img.height);
  auto at = [&](int x, int y) { return img.px[std::size_t(y) * std::size_t(img.width) + std::size_t(x)]; };
  CHECK_TRUE(same(cli::object_colour(0), at(100, 100)));          // the front box, its face lit head-on
  CHECK_TRUE(same(Rgb8{230, 230, 230}, at(155, 155)));           // the plane hides the back box
  CHECK_TRUE(same(Rgb8{230, 230, 230}, at(40, 160)));            // plain plane
  CHECK_TRUE(same(cli::kRenderBackground, at(2, 2)));             // the margin
}

TEST(Render, EmptyCloudIsRefused) {
  io::PointCloud cloud;
  RenderImage img;
  std::string err;
  CHECK_FALSE(cli::render_scene(cloud, {}, RenderOptions{}, img, err));
  STRCMP_EQUAL("the cloud has no points", err.c_str());
}
