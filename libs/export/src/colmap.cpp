// COLMAP's text model (colmap.github.io/format.html): cameras.txt,
// images.txt with each camera's cam_from_world, an empty points3D.txt. One
// COLMAP camera and one image per registered camera; the image's name is
// the camera's label.
#include <sstream>

#include "formats.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::export_detail {
namespace {

struct ColmapCamera {
  std::string model;
  std::vector<double> params;
};

/// COLMAP's model with the same projection, or an Error naming the camera.
ColmapCamera colmapCamera(const std::string& label, const Camera& camera) {
  const std::string model = camera.modelName();
  std::vector<double> p = camera.params();
  if (model == "pinhole") return {"PINHOLE", p};
  if (model == "radtan") {
    // fx fy cx cy k1 k2 p1 p2 k3: OPENCV has no k3, FULL_OPENCV has it.
    if (p[8] == 0) return {"OPENCV", {p.begin(), p.begin() + 8}};
    p.insert(p.end(), {0.0, 0.0, 0.0});
    return {"FULL_OPENCV", p};
  }
  if (model == "rational_polynomial") return {"FULL_OPENCV", p};
  if (model == "kannala_brandt") return {"OPENCV_FISHEYE", p};
  if (model == "fov") return {"FOV", p};
  throw Error("export colmap: camera '" + label + "' has the model '" + model +
              "', which COLMAP does not have (it has pinhole, OpenCV, OpenCV fisheye and FOV "
              "models); fit one with `lookboth camera convert`, or use another format");
}

std::string camerasText(const ExportContext& context) {
  std::ostringstream text;
  text << "# Camera list with one line of data per camera:\n"
       << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
       << "# Number of cameras: " << context.cameras.size() << "\n";
  int id = 1;
  for (const ExportedCamera& c : context.cameras) {
    const Camera& camera = requireIntrinsics(c, "colmap");
    const ColmapCamera colmap = colmapCamera(c.registration->label, camera);
    text << id++ << " " << colmap.model << " " << camera.width() << " " << camera.height();
    for (double v : colmap.params) text << " " << formatDouble(v);
    text << "\n";
  }
  return text.str();
}

std::string imagesText(const ExportContext& context) {
  std::ostringstream text;
  text << "# Image list with two lines of data per image:\n"
       << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
       << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
       << "# Number of images: " << context.cameras.size() << ", mean observations per image: 0\n";
  int id = 1;
  for (const ExportedCamera& c : context.cameras) {
    const Rigid3d camera_from_world = c.registration->world_from_camera.inverse();
    const Eigen::Quaterniond& q = camera_from_world.rotation;
    const Eigen::Vector3d& t = camera_from_world.translation;
    text << id << " " << formatDouble(q.w()) << " " << formatDouble(q.x()) << " "
         << formatDouble(q.y()) << " " << formatDouble(q.z()) << " " << formatDouble(t.x()) << " "
         << formatDouble(t.y()) << " " << formatDouble(t.z()) << " " << id << " "
         << c.registration->label << "\n\n";
    ++id;
  }
  return text.str();
}

}  // namespace

void writeColmap(const ExportContext& context) {
  for (const ExportedCamera& c : context.cameras) {
    if (c.registration->label.find_first_of(" \t") != std::string::npos) {
      throw Error("export colmap: camera '" + c.registration->label +
                  "': COLMAP's image names cannot hold spaces");
    }
  }
  context.write("cameras.txt", camerasText(context));
  context.write("images.txt", imagesText(context));
  context.write("points3D.txt",
                "# 3D point list with one line of data per point:\n"
                "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                "# Number of points: 0, mean track length: 0\n");
}

}  // namespace lookboth::export_detail
