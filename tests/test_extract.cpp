// Surface extraction: the zero-crossing point cloud and the marching-cubes mesh, on volumes filled
// directly from analytic signed distances (sphere, plane, box, random fields).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/volume.hpp"

#include "test_support.hpp"

using namespace edgefuse;

namespace {

constexpr int kDim = 64;
constexpr float kVoxel = 0.005f;
constexpr float kTrunc = 0.02f;  // 4 voxels
constexpr std::size_t kBricks = std::size_t(kDim) * kDim * kDim / kBrickVoxels;
constexpr std::size_t kVoxels = (kBricks + 1) * kBrickVoxels;  // a pool with a slot for every brick
constexpr std::size_t kMaxPoints = 40000;

int16_t g_tsdf[kVoxels];
uint8_t g_weight[kVoxels];
Rgb8 g_colour[kVoxels];
uint8_t g_colour_weight[kVoxels];
uint32_t g_slots[kBricks];
uint8_t g_flags[kBricks];
uint32_t g_list[kBricks];
SurfacePoint g_points[kMaxPoints];
SurfacePoint g_points2[kMaxPoints];
uint32_t g_edge_ids[2 * 3 * kDim * kDim];

TsdfVolume g_volume;

const Vec3f kSphereCentre(0.0013f, -0.0021f, 0.0007f);
constexpr float kSphereRadius = 0.1f;
constexpr float kDeg = 3.14159265f / 180.0f;

//! Fresh volume of dim^3 voxels centred on the world origin.
void setup_volume(int dim = kDim, bool colour = true) {
  VoxelStorage s;
  s.tsdf = g_tsdf;
  s.weight = g_weight;
  s.colour = colour ? g_colour : nullptr;
  s.colour_weight = colour ? g_colour_weight : nullptr;
  s.brick_slot = g_slots;
  s.brick_flags = g_flags;
  s.brick_list = g_list;
  s.capacity_dim = kDim;
  s.pool_bricks = uint32_t(kBricks + 1);
  const float half = 0.5f * float(dim) * kVoxel;
  CHECK(g_volume.init(s, dim, Vec3f(-half, -half, -half), TsdfParams::defaults_for(kVoxel, kTrunc)) ==
        Status::kOk);
  // The tests write voxels directly: every brick gets its slot (in brick order).
  for (std::size_t b = 0; b < g_volume.brick_count(); ++b) CHECK(g_volume.store_brick(b));
}

//! Brick flags as integration leaves them.
void update_flags(TsdfVolume& v) {
  const int nb = v.bricks_per_axis();
  for (std::size_t b = 0; b < v.brick_count(); ++b) {
    uint8_t f = 0;
    for (int i = 0; i < kBrickVoxels; ++i) {
      const std::size_t k = v.brick_base(b) + std::size_t(i);
      if (v.weight()[k] == 0) continue;
      f |= kBrickObserved;
      if (std::abs(int(v.tsdf()[k])) < kTsdfMax) f |= kBrickSurface;
    }
    v.brick_flags()[b] = f;
  }
  for (int bz = 0; bz < nb; ++bz)
    for (int by = 0; by < nb; ++by)
      for (int bx = 0; bx < nb; ++bx) {
        bool near = false;
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int x = bx + dx, y = by + dy, z = bz + dz;
              if (x < 0 || y < 0 || z < 0 || x >= nb || y >= nb || z >= nb) continue;
              if (v.brick_flags()[v.brick_index(x, y, z)] & kBrickSurface) near = true;
            }
        if (near) v.brick_flags()[v.brick_index(bx, by, bz)] |= kBrickNearSurface;
      }
}

int16_t quantise(float d) {
  const float u = std::max(-1.0f, std::min(1.0f, d / kTrunc));
  return int16_t(std::lround(u * float(kTsdfMax)));
}

//! Fills every voxel from sdf(centre); voxels where observed(centre, d) is false keep weight 0 and
//! tsdf +1 (as after clear()). Then sets the brick flags.
template <class Sdf, class Observed>
void fill(TsdfVolume& v, Sdf sdf, Observed observed) {
  const int dim = v.dim();
  for (int z = 0; z < dim; ++z)
    for (int y = 0; y < dim; ++y)
      for (int x = 0; x < dim; ++x) {
        const Vec3f p = v.voxel_centre(x, y, z);
        const float d = sdf(p);
        const std::size_t k = v.index(x, y, z);
        if (observed(p, d)) {
          v.tsdf()[k] = quantise(d);
          v.weight()[k] = 8;
        } else {
          v.tsdf()[k] = kTsdfMax;
          v.weight()[k] = 0;
        }
      }
  update_flags(v);
}

//! Like integration: nothing is stored deeper than the truncation behind the surface.
bool seen_like_integration(const Vec3f&, float d) { return d > -kTrunc; }

float sphere_sdf(const Vec3f& p) { return (p - kSphereCentre).norm() - kSphereRadius; }

void fill_sphere() { fill(g_volume, sphere_sdf, seen_like_integration); }

float angle_between(const Vec3f& a, const Vec3f& b) {
  const float c = a.normalized().dot(b.normalized());
  return std::acos(std::max(-1.0f, std::min(1.0f, c)));
}

//! Reference: every voxel of every brick, in the same order, with index() and no flag skipping.
std::vector<Vec3f> reference_crossings(const TsdfVolume& v) {
  std::vector<Vec3f> out;
  const int nb = v.bricks_per_axis();
  const int dim = v.dim();
  auto usable = [&](std::size_t k) { return v.weight()[k] != 0 && std::abs(int(v.tsdf()[k])) < kTsdfMax; };
  for (int bz = 0; bz < nb; ++bz)
    for (int by = 0; by < nb; ++by)
      for (int bx = 0; bx < nb; ++bx)
        for (int lz = 0; lz < 8; ++lz)
          for (int ly = 0; ly < 8; ++ly)
            for (int lx = 0; lx < 8; ++lx) {
              const int c[3] = {bx * 8 + lx, by * 8 + ly, bz * 8 + lz};
              const std::size_t a = v.index(c[0], c[1], c[2]);
              for (int d = 0; d < 3; ++d) {
                int n[3] = {c[0], c[1], c[2]};
                if (++n[d] >= dim) continue;
                const std::size_t b = v.index(n[0], n[1], n[2]);
                if (!usable(a) || !usable(b)) continue;
                const float ta = v.tsdf()[a], tb = v.tsdf()[b];
                if ((ta < 0) == (tb < 0)) continue;
                const float s = ta / (ta - tb);
                Vec3f f(float(c[0]) + 0.5f, float(c[1]) + 0.5f, float(c[2]) + 0.5f);
                f[d] += s;
                out.push_back(v.origin_m() + f * v.voxel_m());
              }
            }
  return out;
}

struct VectorSink : MeshSink {
  std::vector<Vec3f> position;
  std::vector<Vec3f> normal;
  std::vector<Rgba8> colour;
  std::vector<std::array<uint32_t, 3>> triangles;
  uint32_t add_vertex(const Vec3f& p, const Vec3f& n, const Rgba8& c) override {
    position.push_back(p);
    normal.push_back(n);
    colour.push_back(c);
    return uint32_t(position.size() - 1);
  }
  void add_triangle(uint32_t a, uint32_t b, uint32_t c) override { triangles.push_back({a, b, c}); }
};

struct MeshTopology {
  std::size_t vertices = 0, edges = 0, faces = 0;
  std::size_t boundary_edges = 0;    //!< used by one triangle
  std::size_t nonmanifold_edges = 0; //!< used by more than two triangles
  std::size_t misoriented_edges = 0; //!< a directed edge used twice (inconsistent winding)
  std::size_t bad_indices = 0;       //!< out of range or repeated within a triangle
  std::size_t unused_vertices = 0;
  long euler() const { return long(vertices) - long(edges) + long(faces); }
  bool closed_manifold() const {
    return boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 && bad_indices == 0 &&
           unused_vertices == 0;
  }
};

MeshTopology topology(const VectorSink& m, uint32_t first_vertex = 0, std::size_t first_triangle = 0) {
  MeshTopology t;
  t.vertices = m.position.size() - first_vertex;
  t.faces = m.triangles.size() - first_triangle;
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  std::vector<bool> used(m.position.size(), false);
  for (std::size_t i = first_triangle; i < m.triangles.size(); ++i) {
    const auto& tri = m.triangles[i];
    bool ok = true;
    for (int k = 0; k < 3; ++k) ok = ok && tri[k] >= first_vertex && tri[k] < m.position.size();
    if (!ok || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      ++t.bad_indices;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      used[tri[k]] = true;
      ++directed[{tri[k], tri[(k + 1) % 3]}];
    }
  }
  for (uint32_t v = first_vertex; v < m.position.size(); ++v) t.unused_vertices += !used[v];
  for (const auto& e : directed) {
    if (e.second > 1) ++t.misoriented_edges;
    const auto rev = directed.find({e.first.second, e.first.first});
    const int uses = e.second + (rev == directed.end() ? 0 : rev->second);
    if (e.first.first < e.first.second || rev == directed.end()) {  // count each undirected edge once
      ++t.edges;
      if (uses == 1) ++t.boundary_edges;
      if (uses > 2) ++t.nonmanifold_edges;
    }
  }
  return t;
}

Vec3f triangle_normal(const VectorSink& m, const std::array<uint32_t, 3>& tri) {
  const Vec3f& a = m.position[tri[0]];
  return (m.position[tri[1]] - a).cross(m.position[tri[2]] - a);
}

//! Volume enclosed by the mesh, positive when the triangles face outwards.
double signed_volume(const VectorSink& m) {
  double v = 0;
  for (const auto& tri : m.triangles)
    v += double(m.position[tri[0]].dot(m.position[tri[1]].cross(m.position[tri[2]]))) / 6.0;
  return v;
}

Status mesh(VectorSink& sink, uint8_t min_weight = 0) {
  MeshScratch scratch;
  scratch.edge_ids = g_edge_ids;
  scratch.capacity = sizeof(g_edge_ids) / sizeof(g_edge_ids[0]);
  return extract_mesh(g_volume, scratch, sink, min_weight);
}

bool less_xyz(const Vec3f& a, const Vec3f& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// clang-format off
TEST_GROUP(ExtractPoints) {
  void setup() override { setup_volume(); }
};
// clang-format on

TEST(ExtractPoints, SphereSurfaceNormalsAndCount) {
  fill_sphere();
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  const float area = 4.0f * 3.14159265f * kSphereRadius * kSphereRadius;
  const float expected = 1.5f * area / (kVoxel * kVoxel);  // mean |n_axis| over a sphere = 1/2, 3 axes
  std::printf("\n  sphere: %zu points (expected about %.0f)\n", n, double(expected));
  CHECK(float(n) > 0.95f * expected && float(n) < 1.05f * expected);
  float worst_d = 0, worst_a = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f r = g_points[i].position - kSphereCentre;
    worst_d = std::max(worst_d, std::abs(r.norm() - kSphereRadius));
    worst_a = std::max(worst_a, angle_between(g_points[i].normal, r));
    DOUBLES_EQUAL(1.0, g_points[i].normal.norm(), 1e-5);
    LONGS_EQUAL(0, g_points[i].colour.a);  // colour storage, but nothing fused in colour
  }
  std::printf("  worst distance %.4f voxel, worst normal %.3f deg\n", double(worst_d / kVoxel),
              double(worst_a / kDeg));
  CHECK(worst_d < 0.05f * kVoxel);
  CHECK(worst_a < 2.0f * kDeg);
}

TEST(ExtractPoints, MatchesBruteForceReferenceInOrder) {
  fill_sphere();
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  const std::vector<Vec3f> ref = reference_crossings(g_volume);
  LONGS_EQUAL(ref.size(), n);
  for (std::size_t i = 0; i < n; ++i) CHECK((ref[i] - g_points[i].position).norm() < 1e-6f);
}

TEST(ExtractPoints, Deterministic) {
  fill_sphere();
  std::size_t n1 = 0, n2 = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n1) == Status::kOk);
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n2) == Status::kOk);
  LONGS_EQUAL(n1, n2);
  CHECK(std::memcmp(g_points, g_points2, n1 * sizeof(SurfacePoint)) == 0);
}

TEST(ExtractPoints, Truncation) {
  fill_sphere();
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  std::size_t m = 12345;
  CHECK(extract_points(g_volume, g_points2, n / 2, m) == Status::kOutputTruncated);
  LONGS_EQUAL(n / 2, m);
  CHECK(std::memcmp(g_points, g_points2, m * sizeof(SurfacePoint)) == 0);
  CHECK(extract_points(g_volume, g_points2, n, m) == Status::kOk);  // exactly enough
  LONGS_EQUAL(n, m);
  CHECK(extract_points(g_volume, g_points2, n - 1, m) == Status::kOutputTruncated);
  LONGS_EQUAL(n - 1, m);
  CHECK(extract_points(g_volume, nullptr, 0, m) == Status::kOutputTruncated);
  LONGS_EQUAL(0, m);
  CHECK(extract_points(g_volume, nullptr, 10, m) == Status::kInvalidArgument);
}

TEST(ExtractPoints, ColourInterpolation) {
  fill_sphere();
  // Voxels with x >= 40 seen in colour (r = 4x, g = 2y, b = 100); the others never (their stored
  // colour is garbage that must not leak).
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x) {
        const std::size_t k = g_volume.index(x, y, z);
        if (x >= 40) {
          g_colour[k] = Rgb8{uint8_t(4 * x), uint8_t(2 * y), 100};
          g_colour_weight[k] = 3;
        } else {
          g_colour[k] = Rgb8{17, 99, 201};
          g_colour_weight[k] = 0;
        }
      }
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  std::size_t none = 0, one = 0, both = 0;
  const float eps = 1e-3f;
  for (std::size_t i = 0; i < n; ++i) {
    const SurfacePoint& p = g_points[i];
    const Vec3f f = (p.position - g_volume.origin_m()) / kVoxel - Vec3f::Constant(0.5f);
    if (f.x() < 39.0f - eps) {  // both voxels at x <= 39
      ++none;
      LONGS_EQUAL(0, p.colour.a);
    } else if (f.x() > 39.0f + eps && f.x() < 40.0f - eps) {  // x edge 39 -> 40: voxel 40's colour
      ++one;
      LONGS_EQUAL(255, p.colour.a);
      LONGS_EQUAL(160, p.colour.r);
      LONGS_EQUAL(std::lround(2.0f * f.y()), p.colour.g);
      LONGS_EQUAL(100, p.colour.b);
    } else if (f.x() > 40.0f + eps) {  // both coloured: linear in the position
      ++both;
      LONGS_EQUAL(255, p.colour.a);
      CHECK(std::abs(float(p.colour.r) - 4.0f * f.x()) <= 0.51f);
      CHECK(std::abs(float(p.colour.g) - 2.0f * f.y()) <= 0.51f);
      LONGS_EQUAL(100, p.colour.b);
    }
  }
  std::printf("\n  colour: %zu none, %zu one, %zu both\n", none, one, both);
  CHECK(none > 100 && one > 20 && both > 100);
}

TEST(ExtractPoints, NoColourStorage) {
  setup_volume(kDim, false);
  fill_sphere();
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  CHECK(n > 0);
  for (std::size_t i = 0; i < n; ++i) LONGS_EQUAL(0, g_points[i].colour.a);
}

TEST(ExtractPoints, PlaneIsExact) {
  const float z0 = 0.0123f;
  fill(g_volume, [&](const Vec3f& p) { return p.z() - z0; }, seen_like_integration);
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(kDim * kDim, n);  // one z edge per column
  for (std::size_t i = 0; i < n; ++i) {
    CHECK(std::abs(g_points[i].position.z() - z0) < 1e-3f * kVoxel);
    CHECK((g_points[i].normal - Vec3f(0, 0, 1)).norm() < 1e-5f);
  }
}

TEST(ExtractPoints, PlaneThroughVoxelCentres) {
  // tsdf exactly 0 on a voxel layer: 0 counts as outside, so each column crosses once, at the
  // zero voxel's centre (no duplicate from the edge above it).
  const float z0 = g_volume.voxel_centre(0, 0, 20).z();
  fill(g_volume, [&](const Vec3f& p) { return p.z() - z0; }, seen_like_integration);
  LONGS_EQUAL(0, g_tsdf[g_volume.index(5, 7, 20)]);
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(kDim * kDim, n);
  for (std::size_t i = 0; i < n; ++i) {
    DOUBLES_EQUAL(z0, g_points[i].position.z(), 1e-6);
    CHECK((g_points[i].normal - Vec3f(0, 0, 1)).norm() < 1e-5f);
  }
}

TEST(ExtractPoints, BoxFacesAndEdges) {
  const Vec3f centre(0.0031f, -0.0012f, 0.0022f), half(0.06f, 0.05f, 0.04f);
  auto box = [&](const Vec3f& p) {
    const Vec3f q = (p - centre).cwiseAbs() - half;
    return q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f);
  };
  fill(g_volume, box, seen_like_integration);
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  CHECK(n > 1000);
  std::size_t faces = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = g_points[i].position;
    CHECK(std::abs(box(p)) < 0.3f * kVoxel);  // near edges the interpolation sees rounded level sets
    // Away from the box edges (all but one coordinate > 2 voxels inside the face): exact.
    const Vec3f q = (p - centre).cwiseAbs() - half;
    int axis = 0;
    q.maxCoeff(&axis);
    bool interior = true;
    for (int d = 0; d < 3; ++d)
      if (d != axis && q[d] > -2.0f * kVoxel) interior = false;
    if (!interior) continue;
    ++faces;
    CHECK(std::abs(box(p)) < 0.05f * kVoxel);
    Vec3f normal = Vec3f::Zero();
    normal[axis] = p[axis] > centre[axis] ? 1.0f : -1.0f;
    CHECK(angle_between(g_points[i].normal, normal) < 2.0f * kDeg);
  }
  CHECK(faces > n / 2);
}

TEST(ExtractPoints, UnobservedProducesNothing) {
  fill(g_volume, sphere_sdf, [](const Vec3f&, float) { return false; });
  std::size_t n = 7;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(0, n);
  // Values in band but weights 0 (flags claiming a surface): still nothing.
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x) g_tsdf[g_volume.index(x, y, z)] = quantise(sphere_sdf(g_volume.voxel_centre(x, y, z)));
  std::memset(g_flags, kBrickObserved | kBrickSurface, sizeof(g_flags));
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(0, n);
}

TEST(ExtractPoints, HalfObserved) {
  // Only voxels with x index < 32 observed: no point may use a voxel at x >= 32.
  fill(g_volume, sphere_sdf, [&](const Vec3f& p, float d) {
    return d > -kTrunc && (p.x() - g_volume.origin_m().x()) / kVoxel < 32.0f;
  });
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  CHECK(n > 1000);
  for (std::size_t i = 0; i < n; ++i)
    CHECK((g_points[i].position.x() - g_volume.origin_m().x()) / kVoxel - 0.5f <= 31.0f + 1e-3f);
  const std::vector<Vec3f> ref = reference_crossings(g_volume);
  LONGS_EQUAL(ref.size(), n);
}

TEST(ExtractPoints, NoSurface) {
  fill(g_volume, [](const Vec3f&) { return 1.0f; }, seen_like_integration);  // all +1, observed
  std::size_t n = 7;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(0, n);
  fill(g_volume, [](const Vec3f&) { return 0.5f * kTrunc; }, seen_like_integration);  // in band, no sign change
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(0, n);
  // +1 next to -1 (both truncated): no measured surface, no point.
  fill(g_volume, [](const Vec3f& p) { return p.z() > 0 ? kTrunc : -kTrunc; }, [](const Vec3f&, float) { return true; });
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(0, n);
}

TEST(ExtractPoints, NotInitialised) {
  TsdfVolume v;
  std::size_t n = 7;
  CHECK(extract_points(v, g_points, kMaxPoints, n) == Status::kNotInitialised);
  LONGS_EQUAL(0, n);
}

// ------------------------------------------------------------------------------------------------
// clang-format off
TEST_GROUP(ExtractMesh) {
  void setup() override { setup_volume(); }
};
// clang-format on

TEST(ExtractMesh, SphereClosedManifoldOnSurface) {
  fill_sphere();
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology t = topology(m);
  std::printf("\n  sphere mesh: V %zu E %zu F %zu, Euler %ld\n", t.vertices, t.edges, t.faces, t.euler());
  CHECK(t.faces > 1000);
  CHECK(t.closed_manifold());
  LONGS_EQUAL(2, t.euler());
  LONGS_EQUAL(3 * t.faces, 2 * t.edges);

  float worst_d = 0, worst_a = 0;
  for (std::size_t i = 0; i < m.position.size(); ++i) {
    const Vec3f r = m.position[i] - kSphereCentre;
    worst_d = std::max(worst_d, std::abs(r.norm() - kSphereRadius));
    worst_a = std::max(worst_a, angle_between(m.normal[i], r));
    LONGS_EQUAL(0, m.colour[i].a);
  }
  CHECK(worst_d < 0.05f * kVoxel);
  CHECK(worst_a < 2.0f * kDeg);

  // Winding: (b - a) x (c - a) out of the surface, agreeing with the vertex normals.
  std::size_t checked = 0;
  for (const auto& tri : m.triangles) {
    const Vec3f n = triangle_normal(m, tri);
    if (n.norm() < 1e-4f * kVoxel * kVoxel) continue;  // (near-)degenerate sliver
    ++checked;
    const Vec3f centroid = (m.position[tri[0]] + m.position[tri[1]] + m.position[tri[2]]) / 3.0f;
    CHECK(n.dot(centroid - kSphereCentre) > 0);
    for (int k = 0; k < 3; ++k) CHECK(n.dot(m.normal[tri[k]]) > 0);
  }
  CHECK(checked > m.triangles.size() * 9 / 10);

  // Indexed without duplicates: the vertices are exactly the zero crossings of extract_points.
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  LONGS_EQUAL(n, m.position.size());
  std::vector<Vec3f> a(m.position), b;
  for (std::size_t i = 0; i < n; ++i) b.push_back(g_points[i].position);
  std::sort(a.begin(), a.end(), less_xyz);
  std::sort(b.begin(), b.end(), less_xyz);
  for (std::size_t i = 0; i < n; ++i) CHECK(a[i] == b[i]);
  for (std::size_t i = 1; i < n; ++i) CHECK(!(a[i] == a[i - 1]));
}

TEST(ExtractMesh, ColourAsForPoints) {
  fill_sphere();
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x) {
        const std::size_t k = g_volume.index(x, y, z);
        g_colour[k] = Rgb8{uint8_t(4 * x), uint8_t(2 * y), 100};
        g_colour_weight[k] = x >= 40 ? 3 : 0;
      }
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  std::size_t n = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n) == Status::kOk);
  // Same colour at the same position.
  std::map<std::array<float, 3>, Rgba8> by_pos;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = g_points[i].position;
    by_pos[{p.x(), p.y(), p.z()}] = g_points[i].colour;
  }
  std::size_t coloured = 0;
  for (std::size_t i = 0; i < m.position.size(); ++i) {
    const auto it = by_pos.find({m.position[i].x(), m.position[i].y(), m.position[i].z()});
    CHECK(it != by_pos.end());
    if (it == by_pos.end()) continue;
    LONGS_EQUAL(it->second.a, m.colour[i].a);
    LONGS_EQUAL(it->second.r, m.colour[i].r);
    LONGS_EQUAL(it->second.g, m.colour[i].g);
    LONGS_EQUAL(it->second.b, m.colour[i].b);
    coloured += m.colour[i].a == 255;
  }
  CHECK(coloured > 100 && coloured < m.position.size());
}

TEST(ExtractMesh, BoxClosed) {
  const Vec3f centre(0.0031f, -0.0012f, 0.0022f), half(0.06f, 0.05f, 0.04f);
  fill(g_volume,
       [&](const Vec3f& p) {
         const Vec3f q = (p - centre).cwiseAbs() - half;
         return q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f);
       },
       seen_like_integration);
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology t = topology(m);
  CHECK(t.closed_manifold());
  LONGS_EQUAL(2, t.euler());
}

TEST(ExtractMesh, PlaneIsAGrid) {
  const float z0 = 0.0123f;
  fill(g_volume, [&](const Vec3f& p) { return p.z() - z0; }, seen_like_integration);
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology t = topology(m);
  LONGS_EQUAL(kDim * kDim, t.vertices);
  LONGS_EQUAL(2 * (kDim - 1) * (kDim - 1), t.faces);
  LONGS_EQUAL(4 * (kDim - 1), t.boundary_edges);
  LONGS_EQUAL(0, t.nonmanifold_edges);
  LONGS_EQUAL(0, t.misoriented_edges);
  LONGS_EQUAL(1, t.euler());  // a disc
  for (const auto& tri : m.triangles) CHECK(triangle_normal(m, tri).normalized().z() > 0.9999f);
}

TEST(ExtractMesh, PlaneThroughVoxelCentres) {
  const float z0 = g_volume.voxel_centre(0, 0, 20).z();
  fill(g_volume, [&](const Vec3f& p) { return p.z() - z0; }, seen_like_integration);
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology t = topology(m);
  LONGS_EQUAL(kDim * kDim, t.vertices);
  LONGS_EQUAL(2 * (kDim - 1) * (kDim - 1), t.faces);
  LONGS_EQUAL(1, t.euler());
  LONGS_EQUAL(0, t.nonmanifold_edges);
  LONGS_EQUAL(0, t.misoriented_edges);
  for (const auto& p : m.position) DOUBLES_EQUAL(z0, p.z(), 1e-6);
  for (const auto& tri : m.triangles) CHECK(triangle_normal(m, tri).normalized().z() > 0.9999f);
}

TEST(ExtractMesh, Deterministic) {
  fill_sphere();
  VectorSink a, b;
  CHECK(mesh(a) == Status::kOk);
  CHECK(mesh(b) == Status::kOk);
  LONGS_EQUAL(a.position.size(), b.position.size());
  LONGS_EQUAL(a.triangles.size(), b.triangles.size());
  CHECK(a.position == b.position);
  CHECK(a.normal == b.normal);
  CHECK(a.triangles == b.triangles);
}

TEST(ExtractMesh, UnobservedCellsProduceNothing) {
  fill(g_volume, sphere_sdf, [](const Vec3f&, float) { return false; });
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  LONGS_EQUAL(0, m.position.size());
  LONGS_EQUAL(0, m.triangles.size());
}

TEST(ExtractMesh, HalfObservedIsOpenButConsistent) {
  fill(g_volume, sphere_sdf, [&](const Vec3f& p, float d) {
    return d > -kTrunc && (p.x() - g_volume.origin_m().x()) / kVoxel < 32.0f;
  });
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology t = topology(m);
  CHECK(t.faces > 500);
  CHECK(t.boundary_edges > 0);
  LONGS_EQUAL(0, t.nonmanifold_edges);
  LONGS_EQUAL(0, t.misoriented_edges);
  LONGS_EQUAL(0, t.bad_indices);
  for (const auto& p : m.position) CHECK((p.x() - g_volume.origin_m().x()) / kVoxel - 0.5f <= 31.0f + 1e-3f);
}

TEST(ExtractMesh, NoSurface) {
  fill(g_volume, [](const Vec3f&) { return 1.0f; }, seen_like_integration);
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  LONGS_EQUAL(0, m.position.size());
  fill(g_volume, [](const Vec3f& p) { return p.z() > 0 ? kTrunc : -kTrunc; }, [](const Vec3f&, float) { return true; });
  CHECK(mesh(m) == Status::kOk);  // all corners truncated: an occlusion boundary, not a surface
  LONGS_EQUAL(0, m.position.size());
}

TEST(ExtractMesh, ScratchAndState) {
  fill_sphere();
  VectorSink m;
  MeshScratch small;
  small.edge_ids = g_edge_ids;
  small.capacity = MeshScratch::entries_for(kDim) - 1;
  CHECK(extract_mesh(g_volume, small, m) == Status::kCapacityExceeded);
  MeshScratch null_buffer;
  null_buffer.capacity = MeshScratch::entries_for(kDim);
  CHECK(extract_mesh(g_volume, null_buffer, m) == Status::kInvalidArgument);
  TsdfVolume uninit;
  MeshScratch ok;
  ok.edge_ids = g_edge_ids;
  ok.capacity = MeshScratch::entries_for(kDim);
  CHECK(extract_mesh(uninit, ok, m) == Status::kNotInitialised);
  LONGS_EQUAL(0, m.position.size());
  // Dirty scratch: no effect.
  std::memset(g_edge_ids, 0x5a, sizeof(g_edge_ids));
  CHECK(mesh(m) == Status::kOk);
  CHECK(topology(m).closed_manifold());
}

TEST(ExtractMesh, SinkAlreadyHoldingVertices) {
  // A second mesh appended to the same sink: ids start above 0, sharing must still work.
  fill_sphere();
  VectorSink m;
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology first = topology(m);
  const uint32_t v0 = uint32_t(m.position.size());
  const std::size_t f0 = m.triangles.size();
  CHECK(mesh(m) == Status::kOk);
  const MeshTopology second = topology(m, v0, f0);
  CHECK(second.closed_manifold());
  LONGS_EQUAL(first.vertices, second.vertices);
  LONGS_EQUAL(first.faces, second.faces);
}

TEST(ExtractMesh, SmallerVolumeThanCapacity) {
  setup_volume(24);
  fill(g_volume, [](const Vec3f& p) { return (p - Vec3f(0.001f, 0.002f, -0.001f)).norm() - 0.035f; },
       seen_like_integration);
  VectorSink m;
  MeshScratch s;
  s.edge_ids = g_edge_ids;
  s.capacity = MeshScratch::entries_for(24);
  CHECK(extract_mesh(g_volume, s, m) == Status::kOk);
  const MeshTopology t = topology(m);
  CHECK(t.faces > 100);
  CHECK(t.closed_manifold());
  LONGS_EQUAL(2, t.euler());
}

// Random fields with a positive border: every surface is closed, so each mesh edge must be shared by
// exactly two triangles with opposite directions -- no cracks between cells, consistent winding.
TEST(ExtractMesh, RandomFieldsAreCrackFree) {
  const int dim = 16;
  setup_volume(dim);
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> value(-20000, 20000);
  for (int trial = 0; trial < 40; ++trial) {
    const bool zeros = trial % 4 == 3;  // exact zeros (vertices at voxel centres) in some trials
    for (int z = 0; z < dim; ++z)
      for (int y = 0; y < dim; ++y)
        for (int x = 0; x < dim; ++x) {
          const bool border = x == 0 || y == 0 || z == 0 || x == dim - 1 || y == dim - 1 || z == dim - 1;
          int v = value(rng);
          if (zeros && v % 5 == 0) v = 0;
          const std::size_t k = g_volume.index(x, y, z);
          g_tsdf[k] = int16_t(border ? 20000 : v);
          g_weight[k] = 1;
        }
    update_flags(g_volume);
    VectorSink m;
    CHECK(mesh(m) == Status::kOk);
    const MeshTopology t = topology(m);
    CHECK(t.faces > 100);
    if (!t.closed_manifold())
      std::printf("\n  trial %d: boundary %zu nonmanifold %zu misoriented %zu bad %zu unused %zu\n", trial,
                  t.boundary_edges, t.nonmanifold_edges, t.misoriented_edges, t.bad_indices, t.unused_vertices);
    CHECK(t.closed_manifold());
    CHECK(signed_volume(m) > 0);
  }
}

// Every one of the 256 cases, alone in a cell surrounded by outside voxels: closed and consistent.
TEST(ExtractMesh, AllCasesClosed) {
  const int dim = 8;
  setup_volume(dim);
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> mag(500, 30000);
  for (int c = 1; c < 256; ++c) {
    for (int z = 0; z < dim; ++z)
      for (int y = 0; y < dim; ++y)
        for (int x = 0; x < dim; ++x) {
          g_tsdf[g_volume.index(x, y, z)] = int16_t(mag(rng));
          g_weight[g_volume.index(x, y, z)] = 1;
        }
    for (int i = 0; i < 8; ++i) {
      const int x = 3 + (i == 1 || i == 2 || i == 5 || i == 6);
      const int y = 3 + (i == 2 || i == 3 || i == 6 || i == 7);
      const int z = 3 + (i >= 4);
      if ((c >> i) & 1) g_tsdf[g_volume.index(x, y, z)] = int16_t(-mag(rng));
    }
    update_flags(g_volume);
    VectorSink m;
    CHECK(mesh(m) == Status::kOk);
    const MeshTopology t = topology(m);
    if (!t.closed_manifold()) std::printf("\n  case %d not closed\n", c);
    CHECK(t.closed_manifold());
    CHECK(signed_volume(m) > 0);  // wound outwards around the inside corners
  }
}

// The plane of the support-rule tests: z = kPatchPlaneZ, every observed voxel at weight 8 except
// the columns of a 10 x 5 patch (in_patch), which hold 3 units (e.g. three ToF samples).
namespace {
constexpr float kPatchPlaneZ = 0.0123f;
bool in_patch(int x, int y) { return x >= 10 && x < 20 && y >= 30 && y < 35; }
void fill_plane_with_weak_patch() {
  fill(g_volume, [&](const Vec3f& p) { return p.z() - kPatchPlaneZ; }, seen_like_integration);
  for (int z = 0; z < kDim; ++z)
    for (int y = 0; y < kDim; ++y)
      for (int x = 0; x < kDim; ++x) {
        const std::size_t k = g_volume.index(x, y, z);
        if (g_weight[k] != 0) g_weight[k] = in_patch(x, y) ? 3 : 8;
      }
}
}  // namespace

// The support rule of multi-sensor fusion. A plane filled with weight 8, except a patch of columns whose
// voxels hold 3 units (e.g. three ToF samples); with min_weight 4 the patch's crossings go and
// every other crossing stays, identical; min_weight 0 and 1 are the plain extraction.
TEST(ExtractPoints, MinWeightSupportRule) {
  const float z0 = kPatchPlaneZ;
  fill_plane_with_weak_patch();
  std::size_t n_all = 0, n0 = 0, n1 = 0, n4 = 0, n8 = 0, n9 = 0;
  CHECK(extract_points(g_volume, g_points, kMaxPoints, n_all) == Status::kOk);
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n0, 0) == Status::kOk);
  LONGS_EQUAL(kDim * kDim, n_all);
  LONGS_EQUAL(n_all, n0);
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n1, 1) == Status::kOk);
  LONGS_EQUAL(n_all, n1);
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n4, 4) == Status::kOk);
  LONGS_EQUAL(kDim * kDim - 10 * 5, n4);
  for (std::size_t i = 0; i < n4; ++i) {
    const Vec3f g = (g_points2[i].position - g_volume.origin_m()) / kVoxel;
    CHECK(!in_patch(int(std::floor(g.x())), int(std::floor(g.y()))));
    CHECK(std::abs(g_points2[i].position.z() - z0) < 1e-3f * kVoxel);
  }
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n8, 8) == Status::kOk);
  LONGS_EQUAL(n4, n8);
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n9, 9) == Status::kOk);
  LONGS_EQUAL(0, n9);
}

// The same support rule for marching cubes. The plane of MinWeightSupportRule with
// its 3-unit patch: at min_weight 4 every cell with a corner in a patch column goes (11 x 6 cells:
// the patch's 10 x 5 columns and the cells reaching into them from -x and -y), the mesh's vertices
// are exactly the points extract_points keeps under the same rule, and the rest is the plain mesh.
TEST(ExtractMesh, MinWeightSupportRule) {
  fill_plane_with_weak_patch();
  VectorSink plain, m0, m1, m4, m8, m9;
  CHECK(mesh(plain) == Status::kOk);
  CHECK(mesh(m0, 0) == Status::kOk);
  CHECK(mesh(m1, 1) == Status::kOk);
  CHECK(mesh(m4, 4) == Status::kOk);
  CHECK(mesh(m8, 8) == Status::kOk);
  CHECK(mesh(m9, 9) == Status::kOk);
  LONGS_EQUAL(2 * (kDim - 1) * (kDim - 1), plain.triangles.size());
  CHECK(m0.triangles == plain.triangles && m0.position == plain.position);
  CHECK(m1.triangles == plain.triangles && m1.position == plain.position);

  const MeshTopology t = topology(m4);
  LONGS_EQUAL(2 * ((kDim - 1) * (kDim - 1) - 11 * 6), t.faces);
  LONGS_EQUAL(kDim * kDim - 10 * 5, t.vertices);
  LONGS_EQUAL(0, t.unused_vertices);
  LONGS_EQUAL(0, t.nonmanifold_edges);
  LONGS_EQUAL(0, t.misoriented_edges);
  LONGS_EQUAL(0, t.euler());  // a disc with a hole
  std::size_t n4 = 0;
  CHECK(extract_points(g_volume, g_points2, kMaxPoints, n4, 4) == Status::kOk);
  LONGS_EQUAL(n4, m4.position.size());
  for (const Vec3f& p : m4.position) {
    const Vec3f g = (p - g_volume.origin_m()) / kVoxel;
    CHECK(!in_patch(int(std::floor(g.x())), int(std::floor(g.y()))));
    bool found = false;  // every vertex is a point of the same rule
    for (std::size_t i = 0; i < n4 && !found; ++i) found = (g_points2[i].position - p).norm() < 1e-6f;
    CHECK(found);
  }
  CHECK(m8.triangles == m4.triangles && m8.position == m4.position);
  LONGS_EQUAL(0, m9.triangles.size());
  LONGS_EQUAL(0, m9.position.size());
}
