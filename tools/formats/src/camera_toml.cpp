#include "edgefuse/io/camera_toml.hpp"

#include <cmath>
#include <exception>
#include <new>

#include "file_util.hpp"
#include "text_util.hpp"
#include "toml_util.hpp"

namespace edgefuse::io {

using detail::format;

bool read_camera_toml(const std::string& path, CameraToml& cam, std::string& err) {
  return detail::guarded(path, err, [&] {
    toml::table t;
    if (!detail::parse_toml_file(path, t, err)) return false;
    detail::TomlFields f(t, path, err);
    std::string kind = "pinhole";
    if (!f.get_string("kind", kind, false)) return false;
    if (kind != "pinhole") return f.fail("kind must be \"pinhole\", got \"" + kind + "\"");
    CameraToml out;
    if (!detail::read_pinhole_fields(f, out.intr, false, out.has_min_range, out.has_max_range)) return false;
    if (!f.get_number_array("distortion", out.distortion.coeffs, false)) return false;
    const std::size_t n = out.distortion.coeffs.size();
    // OpenCV's distortion vector lengths; anything else is a typo in the file.
    if (f.has("distortion") && n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
      return f.fail(format("key 'distortion' must hold 4, 5, 8, 12 or 14 numbers (k1 k2 p1 p2 k3 ...), got %zu", n));
    cam = out;
    return true;
  });
}

bool read_camera_toml(const std::string& path, PinholeIntrinsics& intr, std::string& err) {
  CameraToml cam;
  if (!read_camera_toml(path, cam, err)) return false;
  intr = cam.intr;
  return true;
}

bool write_camera_toml(const std::string& path, const CameraToml& cam, std::string& err) {
  const PinholeIntrinsics& k = cam.intr;
  if (k.validate() != Status::kOk) {
    err = path + ": refusing to write invalid intrinsics";
    return false;
  }
  std::string s = "kind = \"pinhole\"\n";
  s += format("width = %d\nheight = %d\n", k.width, k.height);
  s += format("fx = %.9g\nfy = %.9g\ncx = %.9g\ncy = %.9g\n", k.fx, k.fy, k.cx, k.cy);
  s += format("depth_scale = %.9g\nmin_range = %.9g\nmax_range = %.9g\n", k.depth_scale, k.min_range_m,
              k.max_range_m);
  if (!cam.distortion.coeffs.empty()) {
    s += "distortion = [";
    for (std::size_t i = 0; i < cam.distortion.coeffs.size(); ++i)
      s += format(i ? ", %.17g" : "%.17g", cam.distortion.coeffs[i]);
    s += "]\n";
  }
  // TOML needs a decimal point or exponent for floats; %g may print "585": still a valid number,
  // read back as an integer, which the reader accepts for every float key.
  return detail::write_file(path, s.data(), s.size(), err);
}

bool read_intrinsics_matrix_txt(const std::string& path, float& fx, float& fy, float& cx, float& cy,
                                std::string& err) {
  double k[9];
  if (!detail::read_number_matrix(path, 3, 3, "intrinsics matrix", k, err)) return false;
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    err = path + ": not a pinhole K matrix (expected [fx 0 cx; 0 fy cy; 0 0 1])";
    return false;
  }
  if (!(k[0] > 0) || !(k[4] > 0) || k[0] > 1e30 || k[4] > 1e30 || std::fabs(k[2]) > 1e30 || std::fabs(k[5]) > 1e30) {
    err = format("%s: focal lengths must be > 0, got fx=%g fy=%g", path.c_str(), k[0], k[4]);
    return false;
  }
  fx = float(k[0]);
  fy = float(k[4]);
  cx = float(k[2]);
  cy = float(k[5]);
  return true;
}

}  // namespace edgefuse::io
