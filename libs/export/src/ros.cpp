// ROS 2: a URDF with every camera's optical frame as a link fixed under the
// site's frame (site.urdf), the same transforms for tf2's
// static_transform_publisher (static_transforms.launch.py, and
// static_transforms.yaml for other tools), and a camera_info YAML per camera
// (camera_calibration_parsers' layout) named after its frame.
#include <cctype>
#include <sstream>

#include "formats.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::export_detail {
namespace {

std::string frameOf(const CameraRegistration& camera) { return camera.label + "_optical_frame"; }

void checkFrameName(const std::string& label) {
  for (char c : label) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
      throw Error("export ros: camera '" + label +
                  "': a ROS frame name holds letters, digits and '_' only");
    }
  }
}

std::string urdf(const ExportContext& context) {
  const std::string& site = context.options.world_frame;
  std::ostringstream xml;
  xml << "<?xml version=\"1.0\"?>\n"
      << "<!-- lookboth registration of " << context.registration.dataset
      << ": each camera's optical frame (x right, y down, z along the view) in the frame '" << site
      << "' -->\n"
      << "<robot name=\"" << site << "\">\n"
      << "  <link name=\"" << site << "\"/>\n";
  for (const ExportedCamera& c : context.cameras) {
    const Rigid3d& pose = c.registration->world_from_camera;
    const Eigen::Vector3d rpy = rollPitchYaw(pose.rotation.toRotationMatrix());
    const std::string frame = frameOf(*c.registration);
    xml << "  <link name=\"" << frame << "\"/>\n"
        << "  <joint name=\"" << site << "_to_" << frame << "\" type=\"fixed\">\n"
        << "    <parent link=\"" << site << "\"/>\n"
        << "    <child link=\"" << frame << "\"/>\n"
        << "    <origin xyz=\"" << formatDouble(pose.translation.x()) << " "
        << formatDouble(pose.translation.y()) << " " << formatDouble(pose.translation.z())
        << "\" rpy=\"" << formatDouble(rpy.x()) << " " << formatDouble(rpy.y()) << " "
        << formatDouble(rpy.z()) << "\"/>\n"
        << "  </joint>\n";
  }
  xml << "</robot>\n";
  return xml.str();
}

std::string launchFile(const ExportContext& context) {
  std::ostringstream py;
  py << "# ROS 2 launch file written by lookboth export: one static transform per camera.\n"
     << "from launch import LaunchDescription\n"
     << "from launch_ros.actions import Node\n\n\n"
     << "def generate_launch_description():\n"
     << "    return LaunchDescription([\n";
  for (const ExportedCamera& c : context.cameras) {
    const Rigid3d& pose = c.registration->world_from_camera;
    const Eigen::Quaterniond& q = pose.rotation;
    const Eigen::Vector3d& t = pose.translation;
    py << "        Node(package='tf2_ros', executable='static_transform_publisher',\n"
       << "             name='lookboth_" << c.registration->label << "', arguments=[\n"
       << "                 '--x', '" << formatDouble(t.x()) << "', '--y', '" << formatDouble(t.y())
       << "', '--z', '" << formatDouble(t.z()) << "',\n"
       << "                 '--qx', '" << formatDouble(q.x()) << "', '--qy', '"
       << formatDouble(q.y()) << "', '--qz', '" << formatDouble(q.z()) << "', '--qw', '"
       << formatDouble(q.w()) << "',\n"
       << "                 '--frame-id', '" << context.options.world_frame
       << "', '--child-frame-id', '" << frameOf(*c.registration) << "']),\n";
  }
  py << "    ])\n";
  return py.str();
}

std::string transformsYaml(const ExportContext& context) {
  std::ostringstream yaml;
  yaml << "# parent_from_child transforms (m; Hamilton quaternion x y z w)\n"
       << "transforms:\n";
  for (const ExportedCamera& c : context.cameras) {
    const Rigid3d& pose = c.registration->world_from_camera;
    const Eigen::Quaterniond& q = pose.rotation;
    const Eigen::Vector3d& t = pose.translation;
    yaml << "  - parent: " << context.options.world_frame << "\n"
         << "    child: " << frameOf(*c.registration) << "\n"
         << "    status: " << cameraStatusName(c.registration->status) << "\n"
         << "    translation: {x: " << formatDouble(t.x()) << ", y: " << formatDouble(t.y())
         << ", z: " << formatDouble(t.z()) << "}\n"
         << "    rotation: {x: " << formatDouble(q.x()) << ", y: " << formatDouble(q.y())
         << ", z: " << formatDouble(q.z()) << ", w: " << formatDouble(q.w()) << "}\n";
  }
  return yaml.str();
}

/// ROS's distortion model for a camera, with its coefficients; "" when ROS has none.
std::string rosDistortion(const Camera& camera, std::vector<double>* coefficients) {
  const std::string model = camera.modelName();
  const std::vector<double>& p = camera.params();
  if (model == "pinhole") {
    *coefficients = {0, 0, 0, 0, 0};
    return "plumb_bob";
  }
  if (model == "radtan" || model == "rational_polynomial" || model == "kannala_brandt") {
    coefficients->assign(p.begin() + 4, p.end());
    return model == "radtan" ? "plumb_bob"
                             : (model == "kannala_brandt" ? "equidistant" : "rational_polynomial");
  }
  return "";
}

std::string matrixYaml(int rows, int cols, const std::vector<double>& data) {
  std::ostringstream yaml;
  yaml << "\n  rows: " << rows << "\n  cols: " << cols << "\n  data: [";
  for (std::size_t i = 0; i < data.size(); ++i) yaml << (i ? ", " : "") << formatDouble(data[i]);
  yaml << "]\n";
  return yaml.str();
}

std::string cameraInfo(const ExportedCamera& c, const std::string& distortion_model,
                       const std::vector<double>& coefficients) {
  const Camera& camera = *c.intrinsics;
  const std::vector<double>& p = camera.params();
  std::ostringstream yaml;
  yaml << "image_width: " << camera.width() << "\nimage_height: " << camera.height()
       << "\ncamera_name: " << frameOf(*c.registration)
       << "\ncamera_matrix:" << matrixYaml(3, 3, {p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1})
       << "distortion_model: " << distortion_model << "\ndistortion_coefficients:"
       << matrixYaml(1, static_cast<int>(coefficients.size()), coefficients)
       << "rectification_matrix:" << matrixYaml(3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1})
       << "projection_matrix:"
       << matrixYaml(3, 4, {p[0], 0, p[2], 0, 0, p[1], p[3], 0, 0, 0, 1, 0});
  return yaml.str();
}

}  // namespace

void writeRos(const ExportContext& context) {
  for (const ExportedCamera& c : context.cameras) checkFrameName(c.registration->label);
  context.write("site.urdf", urdf(context));
  context.write("static_transforms.launch.py", launchFile(context));
  context.write("static_transforms.yaml", transformsYaml(context));
  for (const ExportedCamera& c : context.cameras) {
    const std::string& label = c.registration->label;
    if (c.intrinsics == nullptr) {
      context.result->notes.push_back(label + ": no camera_info (no calibration in the dataset)");
      continue;
    }
    std::vector<double> coefficients;
    const std::string model = rosDistortion(*c.intrinsics, &coefficients);
    if (model.empty()) {
      context.result->notes.push_back(
          label + ": no camera_info (ROS has no distortion model for '" +
          c.intrinsics->modelName() + "'; fit one with `lookboth camera convert`)");
      continue;
    }
    context.write("camera_info/" + frameOf(*c.registration) + ".yaml",
                  cameraInfo(c, model, coefficients));
  }
}

}  // namespace lookboth::export_detail
