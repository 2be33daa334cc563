#include "edgefuse/io/localize_io.hpp"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>
#include <toml++/toml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <unordered_map>

#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "toml_util.hpp"

namespace edgefuse::io {
namespace {

bool ends_with(const std::string& s, const char* e) {
  const std::size_t n = std::char_traits<char>::length(e);
  return s.size() >= n && s.compare(s.size() - n, n, e) == 0;
}

std::string base_name(const std::string& p) {
  const std::size_t s = p.find_last_of('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

int64_t cell_of(const Vec3f& p, float inv) {
  const int64_t x = int64_t(std::floor(p.x() * inv)) & 0x1FFFFF, y = int64_t(std::floor(p.y() * inv)) & 0x1FFFFF,
                z = int64_t(std::floor(p.z() * inv)) & 0x1FFFFF;
  return (z << 42) | (y << 21) | x;
}

}  // namespace

void estimate_normals_pca(const std::vector<Vec3f>& points, float radius_m, const Vec3f& viewpoint,
                          std::vector<Vec3f>& normals) {
  const float inv = 1.0f / radius_m;
  std::unordered_map<int64_t, std::vector<uint32_t>> grid;
  for (uint32_t i = 0; i < points.size(); ++i)
    if (localizable(points[i])) grid[cell_of(points[i], inv)].push_back(i);
  normals.assign(points.size(), Vec3f::Constant(std::nanf("")));
  for (uint32_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (!localizable(p)) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    int n = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = grid.find(cell_of(p + Vec3f(float(dx), float(dy), float(dz)) * radius_m, inv));
          if (it == grid.end()) continue;
          for (uint32_t j : it->second) {
            if ((points[j] - p).squaredNorm() > radius_m * radius_m) continue;
            const Eigen::Vector3d q = points[j].cast<double>();
            mean += q;
            cov += q * q.transpose();
            ++n;
          }
        }
    if (n < 5) continue;
    mean /= double(n);
    cov = cov / double(n) - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    Vec3f nn = es.eigenvectors().col(0).cast<float>().normalized();
    if (nn.dot(viewpoint - p) < 0) nn = -nn;
    normals[i] = nn;
  }
}

bool load_model(Localizer& loc, const std::string& path, const LocalizeParams& params, int& index, std::string& err) {
  const std::string name = base_name(path);
  Status s;
  if (ends_with(path, ".ply")) {
    io::TriangleMesh mesh;
    if (!io::read_ply(path, mesh, err)) return false;
    if (!mesh.triangles.empty()) {
      std::vector<uint32_t> tri(mesh.triangles.size() * 3);
      for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) tri[t * 3 + std::size_t(k)] = mesh.triangles[t][std::size_t(k)];
      s = loc.add_model(name.c_str(), mesh.vertices.data(), mesh.vertices.size(),
                        reinterpret_cast<const uint32_t(*)[3]>(tri.data()), mesh.triangles.size(), params, index);
      if (s == Status::kInvalidArgument) {
        err = "the mesh has no usable surface (degenerate or zero-area triangles, vertices that are not finite "
              "or lie beyond " + std::to_string(int(kLocalizeCoordMaxM)) + " m, or indices out of range; " +
              std::to_string(mesh.vertices.size()) + " vertices, " +
              std::to_string(mesh.triangles.size()) + " triangles)";
        return false;
      }
      if (s != Status::kOk) {
        err = std::string("cannot load: ") + to_string(s) + " (the board holds " + "at most models_max models)";
        return false;
      }
      return true;
    }
  }
  io::PointCloud cloud;
  if (ends_with(path, ".pcd") ? !io::read_pcd(path, cloud, err) : !io::read_ply(path, cloud, err)) return false;
  std::vector<Vec3f> normals = cloud.normals;
  if (normals.empty()) estimate_normals_pca(cloud.points, 0.01f, Vec3f::Zero(), normals);
  std::vector<OrientedPoint> pts;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (localizable(cloud.points[i]) && normals[i].allFinite()) pts.push_back(OrientedPoint{cloud.points[i], normals[i]});
  s = loc.add_model_cloud(name.c_str(), pts.data(), pts.size(), params, index);
  if (s != Status::kOk) {
    err = s == Status::kInvalidArgument ? "too few points with normals to make a model (" + std::to_string(pts.size()) + ")"
                                        : std::string("cannot load: ") + to_string(s);
    return false;
  }
  return true;
}

bool cloud_scene_points(const io::PointCloud& cloud, std::vector<ScenePoint>& out, std::size_t& beyond, std::string& err) {
  std::vector<Vec3f> normals = cloud.normals;
  if (normals.empty()) {
    if (cloud.organised()) {
      normals.resize(cloud.size());
      organised_normals(cloud.points.data(), cloud.width, cloud.height, 0.02f, normals.data());
    } else {
      estimate_normals_pca(cloud.points, 0.01f, Vec3f::Zero(), normals);
    }
  }
  out.clear();
  // PCD "rgba" fields often carry alpha 0 (PCL writes it so): any colour of a coloured cloud counts.
  auto colour = [&cloud](std::size_t i) {
    if (cloud.colours.empty()) return Rgba8{};
    Rgba8 c = cloud.colours[i];
    c.a = 255;
    return c;
  };
  beyond = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!localizable(cloud.points[i])) {
      beyond += cloud.points[i].allFinite();
      continue;
    }
    if (normals[i].allFinite())
      out.push_back(ScenePoint{cloud.points[i], normals[i].normalized(), uint32_t(i), colour(i)});
  }
  if (out.size() < 100) {
    err = "fewer than 100 points with normals";
    return false;
  }
  return true;
}

bool write_pose_list(const std::string& path, const Localizer& loc, std::size_t count, std::string& err) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    err = path + ": cannot open for writing";
    return false;
  }
  std::fprintf(f, "# edgefuse localize: id tx ty tz qx qy qz qw score model  (T_world_object, picking order)\n");
  for (std::size_t i = 0; i < count; ++i) {
    const LocalizedObject& o = loc.results()[i];
    const Eigen::Quaternionf q = o.T_world_object.quaternion();
    std::fprintf(f, "%zu %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.4f %s\n", i + 1, o.T_world_object.t.x(),
                 o.T_world_object.t.y(), o.T_world_object.t.z(), q.x(), q.y(), q.z(), q.w(), o.score,
                 o.model >= 0 ? loc.model(o.model).name : "segment");
  }
  const bool ok = std::fclose(f) == 0;
  if (!ok) err = path + ": write failed";
  return ok;
}

bool write_segment_labels(const std::string& path, const Localizer& loc, const io::PointCloud& input,
                          std::size_t surface_count, const SurfacePoint* surface, std::string& err) {
  io::PointCloud out;
  if (!input.points.empty()) {
    out.width = input.width;
    out.height = input.height;
    out.points = input.points;
  } else {
    out.points.resize(surface_count);
    for (std::size_t i = 0; i < surface_count; ++i) out.points[i] = surface[i].position;
    out.width = int(surface_count);
    out.height = 1;
  }
  out.labels.assign(out.points.size(), 0u);
  for (std::size_t i = 0; i < loc.scene_count(); ++i) {
    const uint32_t src = loc.scene()[i].source;
    if (src < out.labels.size() && loc.labels()[i] > 0) out.labels[src] = uint32_t(loc.labels()[i]);
  }
  if (ends_with(path, ".ply")) return io::write_ply(path, out, err);
  return io::write_pcd(path, out, err);
}



bool model_files_for(const std::string& spec, const std::string& replay_dir, std::vector<std::string>& out,
                     std::string& err) {
  if (!spec.empty()) {
    if (model_files(spec, out, err)) return true;
    err = "localize.models: " + err;
    return false;
  }
  struct stat st;
  if (replay_dir.empty() || stat(replay_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) ||
      access((replay_dir + "/rig.toml").c_str(), R_OK) != 0)
    return true;
  RigToml rig;
  if (!read_rig_toml(replay_dir + "/rig.toml", rig, err)) return false;
  for (const RigObject& o : rig.objects)
    if (std::find(out.begin(), out.end(), o.model_path) == out.end()) out.push_back(o.model_path);
  return true;
}

bool read_rig_extrinsics(const std::string& folder, std::vector<SensorExtrinsic>& out, std::string& err) {
  const std::string path = folder + "/extrinsics.txt";
  return access(path.c_str(), R_OK) != 0 || read_extrinsics_txt(path, out, err);
}

bool read_bin_toml(const std::string& path, BinGeometry& bin, std::string& err) {
  toml::table t;
  if (!detail::parse_toml_file(path, t, err)) return false;
  auto numbers = [&](const char* key, std::size_t count, double* out) {
    const toml::array* a = t["bin"][key].as_array();
    if (!a || a->size() != count) {
      err = path + ": bin." + key + " must be an array of " + std::to_string(count) + " numbers";
      return false;
    }
    for (std::size_t i = 0; i < count; ++i) {
      const std::optional<double> v = (*a)[i].value<double>();
      if (!v || !std::isfinite(*v)) {
        err = path + ": bin." + key + "[" + std::to_string(i) + "] is not a finite number";
        return false;
      }
      out[i] = *v;
    }
    return true;
  };
  double pose[7], size[2];
  if (!numbers("pose", 7, pose) || !numbers("inner_size_m", 2, size)) return false;
  const double qn = std::sqrt(pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] + pose[6] * pose[6]);
  if (std::fabs(qn - 1.0) > 1e-3) {
    err = path + ": bin.pose quaternion (qx qy qz qw) must have unit length (it has " + std::to_string(qn) + ")";
    return false;
  }
  for (int i = 0; i < 2; ++i)
    if (!(size[i] > 0.0 && size[i] <= 10.0)) {
      err = path + ": bin.inner_size_m[" + std::to_string(i) + "] must be in (0, 10] m";
      return false;
    }
  const Eigen::Quaternionf q(float(pose[6] / qn), float(pose[3] / qn), float(pose[4] / qn), float(pose[5] / qn));
  bin.T_world_bin.R = q.toRotationMatrix();
  bin.T_world_bin.t = Vec3f(float(pose[0]), float(pose[1]), float(pose[2]));
  bin.inner_x_m = float(size[0]);
  bin.inner_y_m = float(size[1]);
  return true;
}


bool read_localize_config(const std::string& path, std::vector<std::string>& models, std::string& bin_file,
                          std::string& err) {
  toml::table t;
  if (!detail::parse_toml_file(path, t, err)) return false;
  const std::size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? std::string(".") : path.substr(0, slash);
  auto resolve = [&dir](const std::string& p) { return p.empty() || p[0] == '/' ? p : dir + "/" + p; };
  auto text = [&](const char* key, std::string& out) {
    const auto node = t["localize"][key];
    if (!node) return true;
    const std::optional<std::string> v = node.value<std::string>();
    if (!v) {
      err = path + ": localize." + key + " must be a path" + (std::string(key) == "models" ? " (a file or folder) or a list of files" : "");
      return false;
    }
    out = resolve(*v);
    return true;
  };
  if (!text("bin", bin_file)) return false;
  if (const toml::array* list = t["localize"]["models"].as_array()) {  // a list of PLY files
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::optional<std::string> v = (*list)[i].value<std::string>();
      if (!v || v->empty()) {
        err = path + ": localize.models[" + std::to_string(i) + "] must be a file path";
        return false;
      }
      models.push_back(resolve(*v));
    }
    return true;
  }
  std::string spec;
  if (!text("models", spec)) return false;
  if (spec.empty()) return true;
  if (!model_files(spec, models, err)) {
    err = path + ": localize.models: " + err;
    return false;
  }
  return true;
}

bool model_files(const std::string& spec, std::vector<std::string>& out, std::string& err) {
  struct stat st;
  if (stat(spec.c_str(), &st) != 0) {
    err = spec + " does not exist";
    return false;
  }
  if (!S_ISDIR(st.st_mode)) {
    out.push_back(spec);
    return true;
  }
  DIR* d = opendir(spec.c_str());
  if (d == nullptr) {
    err = "cannot read the folder " + spec;
    return false;
  }
  std::vector<std::string> names;
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 4 && n.compare(n.size() - 4, 4, ".ply") == 0) names.push_back(spec + "/" + n);
  }
  closedir(d);
  std::sort(names.begin(), names.end());
  if (names.empty()) {
    err = "no .ply model in the folder " + spec;
    return false;
  }
  out.insert(out.end(), names.begin(), names.end());
  return true;
}

}  // namespace edgefuse::io
