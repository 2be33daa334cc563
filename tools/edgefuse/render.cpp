#include "render.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace edgefuse::cli {
namespace {

constexpr float kDegToRad = 3.14159265358979f / 180.0f;
// Objects are drawn this much (metres) in front of the cloud they were fitted to, so the two
// coinciding surfaces do not fight in the depth buffer.
constexpr float kObjectDepthBias_m = 0.003f;

struct View {
  Vec3f right, down, forward;  // image x, image y, viewing direction
  float col0 = 0, row0 = 0;    // scene extent's corner in view coordinates (metres)
  float scale = 1;             // pixels per metre
  float offset_px = 0;         // margin
};

Rgb8 scaled(Rgb8 c, float s) {
  auto ch = [s](uint8_t v) { return uint8_t(std::min(255.0f, std::max(0.0f, float(v) * s))); };
  return Rgb8{ch(c.r), ch(c.g), ch(c.b)};
}

Vec3f mean_normal(const io::PointCloud& cloud) {
  Vec3f sum = Vec3f::Zero();
  for (std::size_t i = 0; i < cloud.normals.size(); ++i)
    if (std::isfinite(cloud.points[i].x()) && cloud.normals[i].allFinite()) sum += cloud.normals[i];
  return sum;
}

View make_view(const io::PointCloud& cloud, const RenderOptions& o, int& height_px) {
  View v;
  const Vec3f n = mean_normal(cloud);
  v.forward = n.norm() > 1e-6f ? Vec3f(-n.normalized()) : Vec3f(0, 0, 1);
  // Image x: the world axis least aligned with the view, made perpendicular to it.
  int least = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(v.forward(k)) < std::fabs(v.forward(least))) least = k;
  const Vec3f a = Vec3f::Unit(least);
  v.right = (a - a.dot(v.forward) * v.forward).normalized();
  v.down = v.forward.cross(v.right);
  const Mat3f tilt = Eigen::AngleAxisf(-o.tilt_deg * kDegToRad, v.right).toRotationMatrix();
  v.forward = tilt * v.forward;
  v.down = tilt * v.down;

  float c0 = std::numeric_limits<float>::max(), c1 = -c0, r0 = c0, r1 = -c0;
  for (const Vec3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    const float c = p.dot(v.right), r = p.dot(v.down);
    c0 = std::min(c0, c), c1 = std::max(c1, c), r0 = std::min(r0, r), r1 = std::max(r1, r);
  }
  v.col0 = c0, v.row0 = r0;
  v.offset_px = o.margin * float(o.width_px);
  v.scale = (float(o.width_px) - 2 * v.offset_px) / std::max(c1 - c0, 1e-6f);
  height_px = int(std::ceil((r1 - r0) * v.scale + 2 * v.offset_px));
  height_px = std::max(16, std::min(height_px, 2 * o.width_px));
  return v;
}

// Screen position (pixels) and depth (metres along the view) of a world point.
Vec3f to_screen(const View& v, const Vec3f& p) {
  return Vec3f((p.dot(v.right) - v.col0) * v.scale + v.offset_px, (p.dot(v.down) - v.row0) * v.scale + v.offset_px,
               p.dot(v.forward));
}

struct Canvas {
  RenderImage& img;
  std::vector<float> depth;
  void put(int x, int y, float z, Rgb8 c) {
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
    const std::size_t i = std::size_t(y) * std::size_t(img.width) + std::size_t(x);
    if (z >= depth[i]) return;
    depth[i] = z;
    img.px[i] = c;
  }
};

void draw_triangle(Canvas& cv, const Vec3f& a, const Vec3f& b, const Vec3f& c, Rgb8 colour) {
  const float area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  if (std::fabs(area) < 1e-9f) return;
  const int x0 = std::max(0, int(std::floor(std::min({a.x(), b.x(), c.x()}))));
  const int x1 = std::min(cv.img.width - 1, int(std::ceil(std::max({a.x(), b.x(), c.x()}))));
  const int y0 = std::max(0, int(std::floor(std::min({a.y(), b.y(), c.y()}))));
  const int y1 = std::min(cv.img.height - 1, int(std::ceil(std::max({a.y(), b.y(), c.y()}))));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const float px = float(x) + 0.5f, py = float(y) + 0.5f;
      const float w0 = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
      const float w1 = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
      const float w2 = 1.0f - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      cv.put(x, y, w0 * a.z() + w1 * b.z() + w2 * c.z() - kObjectDepthBias_m, colour);
    }
}

}  // namespace

Rgb8 object_colour(int i) {
  static const Rgb8 kPalette[] = {{230, 120, 20}, {30, 110, 220}, {40, 170, 60},  {200, 50, 160},
                                  {220, 40, 40},  {20, 170, 170}, {200, 180, 20}, {120, 70, 200}};
  return kPalette[std::size_t(i) % (sizeof(kPalette) / sizeof(kPalette[0]))];
}

bool render_scene(const io::PointCloud& cloud, const std::vector<RenderObject>& objects, const RenderOptions& o,
                  RenderImage& out, std::string& err) {
  std::size_t valid = 0;
  for (const Vec3f& p : cloud.points) valid += p.allFinite() ? 1 : 0;
  if (valid == 0) {
    err = "the cloud has no points";
    return false;
  }
  for (const RenderObject& ob : objects)
    if (ob.mesh == nullptr) {
      err = "an object has no mesh";
      return false;
    }
  int height = 0;
  const View v = make_view(cloud, o, height);
  out.width = o.width_px;
  out.height = height;
  out.px.assign(std::size_t(out.width) * std::size_t(out.height), kRenderBackground);
  Canvas cv{out, std::vector<float>(out.px.size(), std::numeric_limits<float>::max())};

  // Auto point size: squares 1.5 times the mean spacing the points would have over the whole image.
  const int point_px = o.point_px > 0 ? o.point_px
                                      : std::max(1, std::min(8, int(std::ceil(1.5 * std::sqrt(double(out.px.size()) /
                                                                                                double(valid))))));
  const bool has_colour = cloud.colours.size() == cloud.points.size();
  const bool has_normals = cloud.normals.size() == cloud.points.size();
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    Rgb8 c{160, 160, 160};
    if (has_colour && cloud.colours[i].a != 0) {
      c = Rgb8{cloud.colours[i].r, cloud.colours[i].g, cloud.colours[i].b};
    } else if (has_normals && cloud.normals[i].allFinite()) {
      const uint8_t g = uint8_t(90.0f + 140.0f * std::fabs(cloud.normals[i].dot(v.forward)));
      c = Rgb8{g, g, g};
    }
    const Vec3f s = to_screen(v, cloud.points[i]);
    const int x0 = int(std::floor(s.x())) - point_px / 2, y0 = int(std::floor(s.y())) - point_px / 2;
    for (int dy = 0; dy < point_px; ++dy)
      for (int dx = 0; dx < point_px; ++dx) cv.put(x0 + dx, y0 + dy, s.z(), c);
  }

  for (std::size_t k = 0; k < objects.size(); ++k) {
    const io::TriangleMesh& m = *objects[k].mesh;
    const Pose& T = objects[k].T_world_object;
    for (const auto& tri : m.triangles) {
      if (tri[0] >= m.vertices.size() || tri[1] >= m.vertices.size() || tri[2] >= m.vertices.size()) continue;
      const Vec3f a = T * m.vertices[tri[0]], b = T * m.vertices[tri[1]], c = T * m.vertices[tri[2]];
      const Vec3f n = (b - a).cross(c - a);
      const float shade = n.norm() > 0 ? 0.35f + 0.65f * std::fabs(n.normalized().dot(v.forward)) : 1.0f;
      draw_triangle(cv, to_screen(v, a), to_screen(v, b), to_screen(v, c), scaled(object_colour(int(k)), shade));
    }
  }
  return true;
}

}  // namespace edgefuse::cli
