// edgefuse render: a PNG of a fused cloud with the objects of a pose list drawn in as their models.
#include <cstdio>
#include <map>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/io/png.hpp"
#include "eval_poses.hpp"
#include "failure.hpp"
#include "render.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse render CLOUD.ply|.pcd [--poses FILE --models DIR] [--out FILE.png] [--width PX]\n"
    "                       [--tilt DEG] [--point-px N]\n"
    "  Draws the cloud (e.g. `edgefuse fuse --out`; its colours, uncoloured points in grey shaded by\n"
    "  their normal) from a virtual orthographic camera looking along the cloud's mean viewing direction,\n"
    "  turned by --tilt degrees (default 30) about the image's x axis, and each object of a pose list\n"
    "  (`edgefuse localize --out`: id tx ty tz qx qy qz qw score model) as its model mesh DIR/<model>\n"
    "  (or DIR/<model>.ply) at its pose, one colour per object in list order. --width: image width in\n"
    "  pixels (default 800; the height follows the scene). --point-px: size of a cloud point (default:\n"
    "  1.5 x the points' mean spacing over the image, at most 8).\n"
    "  --out: default render.png. Prints one line per object with its colour.\n";

bool is_file(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool read_cloud(const std::string& path, io::PointCloud& cloud, std::string& err) {
  const bool pcd = path.size() > 4 && path.compare(path.size() - 4, 4, ".pcd") == 0;
  return pcd ? io::read_pcd(path, cloud, err) : io::read_ply(path, cloud, err);
}

}  // namespace

int cmd_render(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"poses", "models", "out", "width", "tilt", "point-px"}, {}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse render: %s\n%s", err.empty() ? "expected one CLOUD" : err.c_str(), kUsage);
    return 2;
  }
  RenderOptions o;
  if ((args.has("width") && !args.get_int("width", 64, 8192, o.width_px, err)) ||
      (args.has("point-px") && !args.get_int("point-px", 1, 16, o.point_px, err)) ||
      (args.has("tilt") && !args.get_float("tilt", -89, 89, o.tilt_deg, err)) ||
      (args.has("poses") != args.has("models") && (err = "--poses and --models go together", true))) {
    std::fprintf(stderr, "edgefuse render: %s\n%s", err.c_str(), kUsage);
    return 2;
  }
  const std::string cloud_path = args.positional()[0], out = args.get("out", "render.png");
  io::PointCloud cloud;
  if (!read_cloud(cloud_path, cloud, err)) {
    std::fprintf(stderr, "edgefuse render: %s\n", err.c_str());
    return 1;
  }
  std::vector<PoseLine> poses;
  std::map<std::string, io::TriangleMesh> meshes;
  std::vector<RenderObject> objects;
  if (args.has("poses")) {
    if (!read_pose_lines(args.get("poses"), poses, err)) {
      std::fprintf(stderr, "edgefuse render: %s\n", err.c_str());
      return 1;
    }
    for (const PoseLine& p : poses) {
      const std::string dir = args.get("models");
      std::string path = dir + "/" + p.model;
      if (!is_file(path)) path += ".ply";
      if (p.model.empty() || p.model == "segment" || !is_file(path)) {
        std::fprintf(stderr, "edgefuse render: %s: object %d: no model file %s/%s[.ply]\n", args.get("poses").c_str(),
                     p.id, dir.c_str(), p.model.c_str());
        return 1;
      }
      if (!meshes.count(path) && !io::read_ply(path, meshes[path], err)) {
        std::fprintf(stderr, "edgefuse render: %s\n", err.c_str());
        return 1;
      }
      objects.push_back(RenderObject{&meshes[path], p.T});
    }
  }
  RenderImage img;
  if (!render_scene(cloud, objects, o, img, err)) {
    std::fprintf(stderr, "edgefuse render: %s: %s\n", cloud_path.c_str(), err.c_str());
    return 1;
  }
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Rgb8 c = object_colour(int(i));
    std::printf("object %d %s: colour #%02x%02x%02x\n", poses[i].id, poses[i].model.c_str(), c.r, c.g, c.b);
  }
  if (!io::write_png_rgb8(out, img.px, img.width, img.height, err)) {
    std::fprintf(stderr, "edgefuse render: %s\n", err.c_str());
    return 1;
  }
  std::printf("points=%zu objects=%zu image=%dx%d -> %s\n", cloud.size(), objects.size(), img.width, img.height,
              out.c_str());
  return 0;
}

}  // namespace edgefuse::cli
