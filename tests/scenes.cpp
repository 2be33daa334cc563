#include "scenes.hpp"

#include <cmath>
#include <limits>

namespace edgefuse_test {

void Scene::add_plane(const Vec3f& n, float d, edgefuse::Rgb8 c) {
  items.push_back(Primitive{Primitive::kPlane, n.normalized(), Vec3f(d, 0, 0), Pose{}, c});
}
void Scene::add_sphere(const Vec3f& centre, float radius, edgefuse::Rgb8 c) {
  items.push_back(Primitive{Primitive::kSphere, centre, Vec3f(radius, 0, 0), Pose{}, c});
}
void Scene::add_box(const Vec3f& centre, const Vec3f& half, const Pose& R, edgefuse::Rgb8 c) {
  items.push_back(Primitive{Primitive::kBox, centre, half, R, c});
}

bool Scene::intersect(const Vec3f& o, const Vec3f& dir, float& t_best, Vec3f& n_best, int& item) const {
  t_best = std::numeric_limits<float>::infinity();
  item = -1;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const Primitive& p = items[i];
    float t = -1;
    Vec3f n;
    if (p.kind == Primitive::kPlane) {
      const float den = p.a.dot(dir);
      if (std::fabs(den) < 1e-9f) continue;
      t = -(p.a.dot(o) + p.b.x()) / den;
      n = den < 0 ? p.a : Vec3f(-p.a);
    } else if (p.kind == Primitive::kSphere) {
      const Vec3f oc = o - p.a;
      const float b = oc.dot(dir), c = oc.squaredNorm() - p.b.x() * p.b.x();
      const float disc = b * b - c;
      if (disc < 0) continue;
      t = -b - std::sqrt(disc);
      n = (o + t * dir - p.a).normalized();
    } else {
      // Slab test in the box frame.
      const edgefuse::Mat3f Rt = p.T_world_box.R.transpose();
      const Vec3f ob = Rt * (o - p.a), db = Rt * dir;
      float t0 = -std::numeric_limits<float>::infinity(), t1 = std::numeric_limits<float>::infinity();
      int axis = -1;
      float sign = 1;
      bool miss = false;
      for (int a = 0; a < 3 && !miss; ++a) {
        if (std::fabs(db(a)) < 1e-12f) {
          miss = std::fabs(ob(a)) > p.b(a);
          continue;
        }
        float ta = (-p.b(a) - ob(a)) / db(a), tb = (p.b(a) - ob(a)) / db(a);
        float s = -1;
        if (ta > tb) {
          std::swap(ta, tb);
          s = 1;
        }
        if (ta > t0) {
          t0 = ta;
          axis = a;
          sign = s;
        }
        t1 = std::min(t1, tb);
      }
      if (miss || t0 > t1 || axis < 0) continue;
      t = t0;
      Vec3f nb = Vec3f::Zero();
      nb(axis) = sign;
      n = p.T_world_box.R * nb;
    }
    if (t > 1e-6f && t < t_best) {
      t_best = t;
      n_best = n;
      item = int(i);
    }
  }
  return item >= 0;
}

void render(const Scene& scene, const edgefuse::PinholeIntrinsics& intr, const Pose& T_world_cam,
            std::vector<uint16_t>& depth, std::vector<edgefuse::Rgb8>* colour, std::vector<float>* cos_incidence,
            std::vector<int>* item) {
  const std::size_t n = std::size_t(intr.width) * intr.height;
  depth.assign(n, 0);
  if (colour) colour->assign(n, edgefuse::Rgb8{});
  if (cos_incidence) cos_incidence->assign(n, 0.0f);
  if (item) item->assign(n, -1);
  for (int v = 0; v < intr.height; ++v)
    for (int u = 0; u < intr.width; ++u) {
      const Vec3f ray_c = intr.ray(float(u), float(v));
      const Vec3f dir = (T_world_cam.R * ray_c).normalized();
      float t;
      Vec3f nrm;
      int it;
      if (!scene.intersect(T_world_cam.t, dir, t, nrm, it)) continue;
      const float z = t / ray_c.norm();
      if (z < intr.min_range_m || z > intr.max_range_m) continue;
      const std::size_t i = std::size_t(v) * intr.width + u;
      const double raw = std::round(double(z) * intr.depth_scale);
      if (raw < 1 || raw > 65535) continue;
      depth[i] = uint16_t(raw);
      if (colour) (*colour)[i] = scene.items[std::size_t(it)].colour;
      if (cos_incidence) (*cos_incidence)[i] = std::fabs(nrm.dot(dir));
      if (item) (*item)[i] = it;
    }
}

edgefuse::PinholeIntrinsics bin_rig_a_tof_camera() {
  edgefuse::PinholeIntrinsics c;
  c.width = 160;
  c.height = 120;
  c.fx = 80.0f;
  c.fy = 88.95f;
  c.cx = 79.5f;
  c.cy = 59.5f;
  c.depth_scale = 5000.0f;
  c.min_range_m = 0.1f;
  c.max_range_m = 1.5f;
  return c;
}

Pose look_at(const Vec3f& eye, const Vec3f& target, const Vec3f& down) {
  Pose p;
  const Vec3f z = (target - eye).normalized();
  const Vec3f y = (down - down.dot(z) * z).normalized();
  const Vec3f x = y.cross(z);
  p.R.col(0) = x;
  p.R.col(1) = y;
  p.R.col(2) = z;
  p.t = eye;
  return p;
}

}  // namespace edgefuse_test
