// Camera calibration loaders and the lookboth YAML writer. The accepted
// formats, the fields read and the conversions applied are documented in
// doc/formats.md ("Camera calibration files"); keep the two in step.
#include "lookboth/cameras/camera_io.h"

#include <mrpt/img/TCamera.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <sstream>
#include <utility>
#include <variant>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "structure_check.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Models by name, parameter names

/// Every model except Scaramuzza, whose structure (polynomial degrees) is not
/// known from its name alone.
std::vector<CameraModel> fixedSizeModels() {
  return {PinholeModel{},       RadTanModel{},       RationalPolynomialModel{},
          KannalaBrandtModel{}, DoubleSphereModel{}, EucmModel{},
          MeiModel{},           FovModel{}};
}

std::string scaramuzzaName() { return cameraModelName(CameraModel{ScaramuzzaModel{}}); }

std::string knownModelNames() {
  std::string out;
  for (const CameraModel& model : fixedSizeModels()) out += cameraModelName(model) + ", ";
  return out + scaramuzzaName();
}

/// The fixed-size model called `name`, or nullopt.
std::optional<CameraModel> fixedSizeModelByName(const std::string& name) {
  for (const CameraModel& model : fixedSizeModels()) {
    if (cameraModelName(model) == name) return model;
  }
  return std::nullopt;
}

CameraModel makeScaramuzza(int num_poly, int num_inv_poly) {
  ScaramuzzaModel model;
  model.num_poly = num_poly;
  model.num_inv_poly = num_inv_poly;
  return model;
}

/// Parameter names of a model, in the order of `Camera::params()`.
std::vector<std::string> modelParamNames(const CameraModel& model) {
  return std::visit(
      [](const auto& m) {
        const auto names = m.paramNames();
        std::vector<std::string> out;
        for (const auto& name : names) out.emplace_back(name);
        return out;
      },
      model);
}

/// The first five Scaramuzza parameters, named in lookboth YAML; the
/// polynomials follow as lists.
const std::vector<std::string>& scaramuzzaScalarNames() {
  static const std::vector<std::string> names = {"cx", "cy", "c", "d", "e"};
  return names;
}

bool isScaramuzza(const CameraModel& model) {
  return std::holds_alternative<ScaramuzzaModel>(model);
}

std::string joinNames(const std::vector<std::string>& names, const char* separator = ", ") {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += separator;
    out += names[i];
  }
  return out;
}

std::string describeNumber(double value) { return formatDouble(value); }

/// Validates and builds the camera; a failure becomes an error at `context`.
Camera makeCamera(CameraModel model, int width, int height, std::vector<double> params,
                  const ErrorContext& context) {
  const std::string problem = Camera::validate(model, width, height, params);
  if (!problem.empty()) throw Error(context, problem);
  try {
    return Camera(std::move(model), width, height, std::move(params));
  } catch (const Error& error) {
    throw Error(context, error.message());
  }
}

ErrorContext at(const std::string& file, int line, const std::string& field,
                const std::string& subject = "") {
  ErrorContext context;
  context.file = file;
  context.line = line;
  context.field = field;
  context.subject = subject;
  return context;
}

std::string trim(std::string_view text) {
  size_t begin = 0;
  size_t end = text.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  return std::string(text.substr(begin, end - begin));
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::string line;
  std::istringstream stream(text);
  while (std::getline(stream, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

bool startsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

/// An integral value that fits an int, also written as "5.0".
std::optional<int> parseIntegral(std::string_view text) {
  if (const auto value = parseInt(text)) {
    if (*value >= std::numeric_limits<int>::min() && *value <= std::numeric_limits<int>::max()) {
      return static_cast<int>(*value);
    }
    return std::nullopt;
  }
  if (const auto value = parseDouble(text)) {
    if (std::isfinite(*value) && std::floor(*value) == *value && std::abs(*value) < 1e9) {
      return static_cast<int>(*value);
    }
  }
  return std::nullopt;
}

// ---------------------------------------------------------------------------
// yaml-cpp helpers: every read names the field and, when known, the line.

int lineOf(const YAML::Node& node) {
  if (!node.IsDefined()) return 0;
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

const char* nodeKind(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
      return "nothing";
    case YAML::NodeType::Null:
      return "an empty value";
    case YAML::NodeType::Scalar:
      return "a single value";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
  }
  return "something else";
}

YAML::Node parseYaml(const std::string& text, const std::string& file) {
  try {
    checkYamlStructure(text, file);
    return YAML::Load(text);
  } catch (const YAML::Exception& error) {
    const int line = error.mark.is_null() ? 0 : error.mark.line + 1;
    throw Error(at(file, line, ""), "YAML syntax error: " + error.msg);
  }
}

/// Reads YAML nodes of one file; `prefix` is prepended to field names
/// ("cam1." for a Kalibr camera).
class YamlFields {
 public:
  YamlFields(std::string file, std::string prefix = "")
      : file_(std::move(file)), prefix_(std::move(prefix)) {}

  const std::string& file() const { return file_; }
  std::string field(const std::string& name) const { return prefix_ + name; }
  ErrorContext context(const YAML::Node& node, const std::string& name) const {
    return at(file_, lineOf(node), field(name));
  }

  /// The value of `key` in `map`; throws when it is absent or empty.
  YAML::Node require(const YAML::Node& map, const std::string& key) const {
    const YAML::Node node = map[key];
    if (!node.IsDefined()) throw Error(at(file_, 0, field(key)), "missing");
    if (node.IsNull()) throw Error(context(node, key), "has no value");
    return node;
  }

  double number(const YAML::Node& node, const std::string& name) const {
    if (!node.IsScalar()) {
      throw Error(context(node, name), std::string("expected a number, got ") + nodeKind(node));
    }
    const auto value = parseDouble(node.Scalar());
    if (!value || !std::isfinite(*value)) {
      throw Error(context(node, name), "not a finite number: " + excerpt(node.Scalar()));
    }
    return *value;
  }

  int integer(const YAML::Node& node, const std::string& name) const {
    if (!node.IsScalar()) {
      throw Error(context(node, name), std::string("expected an integer, got ") + nodeKind(node));
    }
    const auto value = parseIntegral(node.Scalar());
    if (!value) throw Error(context(node, name), "not an integer: " + excerpt(node.Scalar()));
    return *value;
  }

  std::string text(const YAML::Node& node, const std::string& name) const {
    if (!node.IsScalar()) {
      throw Error(context(node, name), std::string("expected a name, got ") + nodeKind(node));
    }
    return node.Scalar();
  }

  /// A list of numbers; an empty value counts as an empty list.
  std::vector<double> numbers(const YAML::Node& node, const std::string& name) const {
    std::vector<double> out;
    if (node.IsNull()) return out;
    if (!node.IsSequence()) {
      throw Error(context(node, name),
                  std::string("expected a list of numbers, got ") + nodeKind(node));
    }
    for (size_t i = 0; i < node.size(); ++i) {
      out.push_back(number(node[i], name + "[" + std::to_string(i) + "]"));
    }
    return out;
  }

  std::vector<int> integers(const YAML::Node& node, const std::string& name) const {
    std::vector<int> out;
    if (!node.IsSequence()) {
      throw Error(context(node, name),
                  std::string("expected a list of integers, got ") + nodeKind(node));
    }
    for (size_t i = 0; i < node.size(); ++i) {
      out.push_back(integer(node[i], name + "[" + std::to_string(i) + "]"));
    }
    return out;
  }

  void requireMap(const YAML::Node& node, const std::string& name) const {
    if (!node.IsMap()) {
      throw Error(context(node, name.empty() ? "" : name),
                  std::string("expected a map of keys, got ") + nodeKind(node));
    }
  }

 private:
  std::string file_;
  std::string prefix_;
};

/// Runs a YAML reader; yaml-cpp exceptions that slip past the checks (e.g. a
/// subscript into a value that is not a map) become errors naming the file.
template <typename Function>
auto guardYaml(const std::string& file, Function&& function) -> decltype(function()) {
  try {
    return function();
  } catch (const YAML::Exception& error) {
    const int line = error.mark.is_null() ? 0 : error.mark.line + 1;
    throw Error(at(file, line, ""), "unexpected YAML structure: " + error.msg);
  }
}

// ---------------------------------------------------------------------------
// lookboth YAML

constexpr int kLookbothFormatVersion = 1;

Camera parseLookbothYaml(const std::string& yaml, const std::string& source) {
  const YamlFields in(source);
  const YamlFields in_params(source, "params.");
  const YAML::Node root = parseYaml(yaml, source);
  if (!root.IsMap()) {
    throw Error(at(source, lineOf(root), ""),
                std::string("expected a lookboth camera (a map with 'lookboth_camera: 1'), got ") +
                    nodeKind(root));
  }
  static const std::vector<std::string> kKeys = {"lookboth_camera", "model", "width",   "height",
                                                 "params",          "poly",  "inv_poly"};
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if (std::find(kKeys.begin(), kKeys.end(), key) == kKeys.end()) {
      throw Error(in.context(entry.first, shortenedName(key)),
                  "unknown key (expected " + joinNames(kKeys) + ")");
    }
  }
  const YAML::Node version_node = in.require(root, "lookboth_camera");
  const int version = in.integer(version_node, "lookboth_camera");
  if (version != kLookbothFormatVersion) {
    throw Error(in.context(version_node, "lookboth_camera"),
                "unsupported format version " + std::to_string(version) + " (this lookboth reads " +
                    std::to_string(kLookbothFormatVersion) + ")");
  }
  const YAML::Node model_node = in.require(root, "model");
  const std::string model_name = in.text(model_node, "model");
  const int width = in.integer(in.require(root, "width"), "width");
  const int height = in.integer(in.require(root, "height"), "height");
  const YAML::Node params_node = in.require(root, "params");
  in.requireMap(params_node, "params");

  CameraModel model = PinholeModel{};
  std::vector<std::string> scalar_names;
  std::vector<double> poly;
  std::vector<double> inv_poly;
  if (model_name == scaramuzzaName()) {
    scalar_names = scaramuzzaScalarNames();
    const YAML::Node poly_node = in.require(root, "poly");
    poly = in.numbers(poly_node, "poly");
    if (poly.empty())
      throw Error(in.context(poly_node, "poly"), "must hold at least one coefficient");
    if (root["inv_poly"].IsDefined()) inv_poly = in.numbers(root["inv_poly"], "inv_poly");
    model = makeScaramuzza(static_cast<int>(poly.size()), static_cast<int>(inv_poly.size()));
  } else {
    const auto found = fixedSizeModelByName(model_name);
    if (!found) {
      throw Error(in.context(model_node, "model"), "unknown camera model " + excerpt(model_name) +
                                                       " (known: " + knownModelNames() + ")");
    }
    model = *found;
    scalar_names = modelParamNames(model);
    for (const char* key : {"poly", "inv_poly"}) {
      if (root[key].IsDefined()) {
        throw Error(in.context(root[key], key),
                    "only a " + scaramuzzaName() + " camera has this key, not " + model_name);
      }
    }
  }

  for (const auto& entry : params_node) {
    const std::string key = entry.first.Scalar();
    if (std::find(scalar_names.begin(), scalar_names.end(), key) == scalar_names.end()) {
      throw Error(in.context(entry.first, "params." + shortenedName(key)),
                  "unknown parameter for model " + model_name + " (expected " +
                      joinNames(scalar_names) + ")");
    }
  }
  std::vector<double> params;
  for (const std::string& name : scalar_names) {
    params.push_back(in_params.number(in_params.require(params_node, name), name));
  }
  params.insert(params.end(), poly.begin(), poly.end());
  params.insert(params.end(), inv_poly.begin(), inv_poly.end());
  return makeCamera(std::move(model), width, height, std::move(params), at(source, 0, ""));
}

std::string writeLookbothYaml(const Camera& camera) {
  const std::vector<double>& params = camera.params();
  std::ostringstream out;
  out << "# lookboth camera calibration (format: doc/formats.md, \"Camera calibration files\")\n";
  out << "lookboth_camera: " << kLookbothFormatVersion << "\n";
  out << "model: " << camera.modelName() << "\n";
  out << "width: " << camera.width() << "\n";
  out << "height: " << camera.height() << "\n";
  out << "params:\n";
  if (isScaramuzza(camera.model())) {
    const auto& model = std::get<ScaramuzzaModel>(camera.model());
    const auto& names = scaramuzzaScalarNames();
    for (size_t i = 0; i < names.size(); ++i) {
      out << "  " << names[i] << ": " << formatDouble(params[i]) << "\n";
    }
    auto writeList = [&](const char* key, size_t begin, size_t count) {
      out << key << ": [";
      for (size_t i = 0; i < count; ++i)
        out << (i > 0 ? ", " : "") << formatDouble(params[begin + i]);
      out << "]\n";
    };
    const size_t num_poly = static_cast<size_t>(model.num_poly);
    writeList("poly", names.size(), num_poly);
    writeList("inv_poly", names.size() + num_poly, static_cast<size_t>(model.num_inv_poly));
  } else {
    const std::vector<std::string> names = modelParamNames(camera.model());
    for (size_t i = 0; i < names.size() && i < params.size(); ++i) {
      out << "  " << names[i] << ": " << formatDouble(params[i]) << "\n";
    }
  }
  return out.str();
}

// ---------------------------------------------------------------------------
// ROS camera_info YAML (camera_calibration_parsers)

/// A {rows, cols, data} matrix; checks rows * cols == data size.
std::vector<double> readRosMatrix(const YamlFields& in, const YAML::Node& root,
                                  const std::string& key, int* rows_out, int* cols_out) {
  const YAML::Node node = in.require(root, key);
  in.requireMap(node, key);
  const int rows = in.integer(in.require(node, "rows"), key + ".rows");
  const int cols = in.integer(in.require(node, "cols"), key + ".cols");
  const YAML::Node data_node = node["data"];
  if (!data_node.IsDefined()) throw Error(at(in.file(), lineOf(node), key + ".data"), "missing");
  std::vector<double> data = in.numbers(data_node, key + ".data");
  if (rows < 0 || cols < 0 ||
      static_cast<size_t>(rows) * static_cast<size_t>(cols) != data.size()) {
    throw Error(in.context(data_node, key + ".data"),
                "rows x cols = " + std::to_string(rows) + " x " + std::to_string(cols) + " but " +
                    std::to_string(data.size()) + " numbers are given");
  }
  *rows_out = rows;
  *cols_out = cols;
  return data;
}

Camera loadRosCameraInfo(const std::string& text, const std::string& file) {
  const YamlFields in(file);
  const YAML::Node root = parseYaml(text, file);
  in.requireMap(root, "");
  const int width = in.integer(in.require(root, "image_width"), "image_width");
  const int height = in.integer(in.require(root, "image_height"), "image_height");
  std::string subject;
  if (root["camera_name"].IsDefined() && root["camera_name"].IsScalar()) {
    subject = shortenedName(root["camera_name"].Scalar());
  }

  int rows = 0;
  int cols = 0;
  const std::vector<double> k = readRosMatrix(in, root, "camera_matrix", &rows, &cols);
  const int k_line = lineOf(root["camera_matrix"]["data"]);
  if (rows != 3 || cols != 3) {
    throw Error(at(file, lineOf(root["camera_matrix"]), "camera_matrix", subject),
                "must be 3 x 3, got " + std::to_string(rows) + " x " + std::to_string(cols));
  }
  if (k[1] != 0.0) {
    throw Error(at(file, k_line, "camera_matrix.data", subject),
                "skew K[0][1] = " + describeNumber(k[1]) +
                    " is not zero; lookboth camera models have no skew");
  }
  if (k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0) {
    throw Error(
        at(file, k_line, "camera_matrix.data", subject),
        "not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]: K[1][0], K[2][0], K[2][1] must be 0 and "
        "K[2][2] must be 1");
  }

  const YAML::Node model_node = in.require(root, "distortion_model");
  const std::string distortion = in.text(model_node, "distortion_model");
  const std::vector<double> d = readRosMatrix(in, root, "distortion_coefficients", &rows, &cols);
  const int d_line = lineOf(root["distortion_coefficients"]["data"]);
  if (!d.empty() && rows != 1 && cols != 1) {
    throw Error(at(file, d_line, "distortion_coefficients", subject),
                "must be a single row, got " + std::to_string(rows) + " x " + std::to_string(cols));
  }
  std::vector<double> params = {k[0], k[4], k[2], k[5]};
  CameraModel model = PinholeModel{};
  auto wrongCount = [&](const std::string& expected) {
    return Error(at(file, d_line, "distortion_coefficients.data", subject),
                 "distortion_model " + distortion + " needs " + expected + " coefficients, got " +
                     std::to_string(d.size()));
  };
  if (distortion == "plumb_bob") {
    if (d.empty()) {
      model = PinholeModel{};
    } else if (d.size() == 5 || d.size() == 4) {
      model = RadTanModel{};
      params.insert(params.end(), d.begin(), d.end());
      if (d.size() == 4) params.push_back(0.0);  // k3
    } else {
      throw wrongCount("5 (k1 k2 p1 p2 k3; or 4 with k3 = 0, or none)");
    }
  } else if (distortion == "rational_polynomial") {
    if (d.size() != 8) throw wrongCount("8 (k1 k2 p1 p2 k3 k4 k5 k6)");
    model = RationalPolynomialModel{};
    params.insert(params.end(), d.begin(), d.end());
  } else if (distortion == "equidistant") {
    if (d.size() != 4) throw wrongCount("4 (k1 k2 k3 k4)");
    model = KannalaBrandtModel{};
    params.insert(params.end(), d.begin(), d.end());
  } else {
    throw Error(at(file, lineOf(model_node), "distortion_model", subject),
                "unsupported distortion model " + excerpt(distortion) +
                    " (supported: plumb_bob, rational_polynomial, equidistant)");
  }
  return makeCamera(std::move(model), width, height, std::move(params), at(file, 0, "", subject));
}

// ---------------------------------------------------------------------------
// Kalibr camchain YAML

std::vector<std::string> kalibrCameraNames(const YAML::Node& root) {
  std::vector<std::pair<long long, std::string>> found;
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if (key.size() > 3 && startsWith(key, "cam")) {
      if (const auto index = parseInt(key.substr(3))) {
        if (std::all_of(key.begin() + 3, key.end(),
                        [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; })) {
          found.emplace_back(*index, key);
        }
      }
    }
  }
  std::sort(found.begin(), found.end());
  std::vector<std::string> names;
  for (const auto& item : found) names.push_back(item.second);
  return names;
}

/// The cameras of a camchain for a message: a broken file may hold thousands.
std::string cameraList(const std::vector<std::string>& names) {
  constexpr size_t kMaxNames = 10;
  if (names.size() <= kMaxNames) return joinNames(names);
  const std::vector<std::string> first(names.begin(), names.begin() + kMaxNames);
  return joinNames(first) + ", ... (" + std::to_string(names.size()) + " cameras)";
}

Camera loadKalibrCamera(const YAML::Node& node, const std::string& name, const std::string& file) {
  YamlFields(file).requireMap(node, name);
  const YamlFields in(file, name + ".");
  const YAML::Node model_node = in.require(node, "camera_model");
  const std::string camera_model = in.text(model_node, "camera_model");
  const YAML::Node intrinsics_node = in.require(node, "intrinsics");
  const std::vector<double> intrinsics = in.numbers(intrinsics_node, "intrinsics");
  const YAML::Node distortion_node = in.require(node, "distortion_model");
  const std::string distortion = in.text(distortion_node, "distortion_model");
  const YAML::Node coeffs_node = node["distortion_coeffs"];
  std::vector<double> coeffs;
  if (coeffs_node.IsDefined()) coeffs = in.numbers(coeffs_node, "distortion_coeffs");
  const YAML::Node resolution_node = in.require(node, "resolution");
  const std::vector<int> resolution = in.integers(resolution_node, "resolution");
  if (resolution.size() != 2) {
    throw Error(in.context(resolution_node, "resolution"),
                "expected [width, height], got " + std::to_string(resolution.size()) + " numbers");
  }

  const std::string combination = camera_model + "-" + distortion;
  const std::string supported =
      "supported: pinhole-radtan, pinhole-equidistant, pinhole-fov, pinhole-none, ds-none, "
      "eucm-none, omni-radtan, omni-none";
  auto expectCount = [&](const YAML::Node& where, const std::string& field, size_t got, size_t want,
                         const std::string& what) {
    if (got != want) {
      throw Error(in.context(where, field), combination + " needs " + std::to_string(want) +
                                                " numbers " + what + ", got " +
                                                std::to_string(got));
    }
  };
  auto refuseCombination = [&] {
    throw Error(at(file, lineOf(distortion_node), name + ".distortion_model"),
                "camera model " + excerpt(combination) + " is not supported (" + supported + ")");
  };
  CameraModel model = PinholeModel{};
  std::vector<double> params;
  if (camera_model == "pinhole") {
    expectCount(intrinsics_node, "intrinsics", intrinsics.size(), 4, "[fu fv pu pv]");
    params = intrinsics;
    if (distortion == "radtan") {
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 4, "[k1 k2 p1 p2]");
      model = RadTanModel{};
      params.insert(params.end(), coeffs.begin(), coeffs.end());
      params.push_back(0.0);  // k3: Kalibr's radtan has none
    } else if (distortion == "equidistant") {
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 4, "[k1 k2 k3 k4]");
      model = KannalaBrandtModel{};
      params.insert(params.end(), coeffs.begin(), coeffs.end());
    } else if (distortion == "fov") {
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 1, "[w]");
      model = FovModel{};
      params.push_back(coeffs[0]);
    } else if (distortion == "none") {
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 0, "(no distortion)");
      model = PinholeModel{};
    } else {
      refuseCombination();
    }
  } else if (camera_model == "ds" || camera_model == "eucm") {
    // Two shape parameters first in Kalibr ([xi alpha] / [alpha beta] fu fv pu pv), last in
    // lookboth.
    const bool ds = camera_model == "ds";
    if (distortion != "none") refuseCombination();
    expectCount(intrinsics_node, "intrinsics", intrinsics.size(), 6,
                ds ? "[xi alpha fu fv pu pv]" : "[alpha beta fu fv pu pv]");
    expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 0, "(no distortion)");
    model = ds ? CameraModel{DoubleSphereModel{}} : CameraModel{EucmModel{}};
    params = {intrinsics[2], intrinsics[3], intrinsics[4],
              intrinsics[5], intrinsics[0], intrinsics[1]};
  } else if (camera_model == "omni") {
    if (distortion != "radtan" && distortion != "none") refuseCombination();
    expectCount(intrinsics_node, "intrinsics", intrinsics.size(), 5, "[xi fu fv pu pv]");
    if (distortion == "radtan")
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 4, "[k1 k2 p1 p2]");
    else
      expectCount(coeffs_node, "distortion_coeffs", coeffs.size(), 0, "(no distortion)");
    model = MeiModel{};
    // lookboth order: fx fy cx cy xi k1 k2 p1 p2.
    params = {intrinsics[1], intrinsics[2], intrinsics[3], intrinsics[4], intrinsics[0]};
    if (coeffs.empty()) coeffs.assign(4, 0.0);
    params.insert(params.end(), coeffs.begin(), coeffs.end());
  } else {
    throw Error(at(file, lineOf(model_node), name + ".camera_model"),
                "camera model " + excerpt(combination) + " is not supported (" + supported + ")");
  }
  return makeCamera(std::move(model), resolution[0], resolution[1], std::move(params),
                    at(file, lineOf(intrinsics_node), name + ".intrinsics"));
}

std::map<std::string, Camera> loadKalibr(const std::string& text, const std::string& file,
                                         const std::string& only) {
  const YamlFields in(file);
  const YAML::Node root = parseYaml(text, file);
  in.requireMap(root, "");
  const std::vector<std::string> names = kalibrCameraNames(root);
  if (names.empty()) {
    throw Error(at(file, 0, "cam0"), "missing: a Kalibr camchain holds cameras cam0, cam1, ...");
  }
  std::map<std::string, Camera> cameras;
  if (!only.empty()) {
    if (std::find(names.begin(), names.end(), only) == names.end()) {
      throw Error(at(file, 0, only),
                  "no such camera in the camchain (it has " + cameraList(names) + ")");
    }
    cameras.emplace(only, loadKalibrCamera(root[only], only, file));
    return cameras;
  }
  for (const std::string& name : names)
    cameras.emplace(name, loadKalibrCamera(root[name], name, file));
  return cameras;
}

// ---------------------------------------------------------------------------
// OCamCalib calib_results.txt

/// One block of numbers on one line of calib_results.txt.
struct OCamLine {
  int line = 0;
  std::vector<std::string> tokens;
};

std::vector<double> ocamNumbers(const OCamLine& data, size_t first, const std::string& file,
                                const std::string& block) {
  std::vector<double> out;
  for (size_t i = first; i < data.tokens.size(); ++i) {
    const auto value = parseDouble(data.tokens[i]);
    if (!value || !std::isfinite(*value)) {
      throw Error(at(file, data.line, block), "not a number: " + excerpt(data.tokens[i]));
    }
    out.push_back(*value);
  }
  return out;
}

/// A length-prefixed list: "<count> v0 v1 ... v{count-1}".
std::vector<double> ocamCountedList(const OCamLine& data, const std::string& file,
                                    const std::string& block) {
  const auto count = parseIntegral(data.tokens.front());
  if (!count || *count < 1) {
    throw Error(at(file, data.line, block),
                "expected the number of coefficients (a positive integer) first, got " +
                    excerpt(data.tokens.front()));
  }
  const size_t got = data.tokens.size() - 1;
  if (got != static_cast<size_t>(*count)) {
    throw Error(at(file, data.line, block), "expected " + std::to_string(*count) +
                                                " numbers after the count, got " +
                                                std::to_string(got));
  }
  return ocamNumbers(data, 1, file, block);
}

std::vector<double> ocamFixedList(const OCamLine& data, size_t count, const std::string& file,
                                  const std::string& block, const std::string& what) {
  if (data.tokens.size() != count) {
    throw Error(at(file, data.line, block), "expected " + std::to_string(count) + " numbers (" +
                                                what + "), got " +
                                                std::to_string(data.tokens.size()));
  }
  return ocamNumbers(data, 0, file, block);
}

/// The block a header comment of calib_results.txt names (an index into the
/// blocks loadOCamCalib reads), or nullopt for any other comment.
std::optional<size_t> ocamHeaderBlock(const std::string& comment) {
  std::string lower = trim(std::string_view(comment).substr(1));
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (startsWith(lower, "polynomial coefficients")) {
    return lower.find("inverse") != std::string::npos ? size_t{1} : size_t{0};
  }
  if (startsWith(lower, "center")) return size_t{2};
  if (startsWith(lower, "affine parameters")) return size_t{3};
  if (startsWith(lower, "image size")) return size_t{4};
  return std::nullopt;
}

Camera loadOCamCalib(const std::string& text, const std::string& file) {
  // Blocks in the order OCamCalib writes them; comments ('#') and blank
  // lines between them are skipped, each block is one line of numbers.
  static const char* const kBlocks[] = {"polynomial coefficients",
                                        "inverse polynomial coefficients", "center",
                                        "affine parameters", "image size"};
  constexpr size_t kNumBlocks = sizeof(kBlocks) / sizeof(kBlocks[0]);
  std::vector<OCamLine> data;
  const std::vector<std::string> lines = splitLines(text);
  // The header comments name the blocks: one named twice means two blocks
  // for one (as when two files were joined), and reading them by position
  // would take the wrong numbers for the wrong block.
  std::map<size_t, int> header_lines;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string content = trim(lines[i]);
    const int line = static_cast<int>(i) + 1;
    if (!content.empty() && content[0] == '#') {
      if (const auto block = ocamHeaderBlock(content)) {
        const auto [first, inserted] = header_lines.emplace(*block, line);
        if (!inserted) {
          throw Error(at(file, line, kBlocks[*block]), "duplicate block header (first at line " +
                                                           std::to_string(first->second) + ")");
        }
      }
    }
    if (content.empty() || content[0] == '#') continue;
    data.push_back({line, splitWhitespace(content)});
  }
  auto block = [&](size_t index) -> const OCamLine& {
    if (index >= data.size()) {
      throw Error(
          at(file, static_cast<int>(lines.size()), kBlocks[index]),
          "missing: the file ends before it (calib_results.txt has five blocks: polynomial, "
          "inverse polynomial, center, affine, image size)");
    }
    return data[index];
  };
  const std::vector<double> poly = ocamCountedList(block(0), file, kBlocks[0]);
  const std::vector<double> inv_poly = ocamCountedList(block(1), file, kBlocks[1]);
  const std::vector<double> center = ocamFixedList(block(2), 2, file, kBlocks[2], "row and column");
  const std::vector<double> affine = ocamFixedList(block(3), 3, file, kBlocks[3], "c d e");
  const OCamLine& size_line = block(4);
  if (size_line.tokens.size() != 2) {
    throw Error(
        at(file, size_line.line, kBlocks[4]),
        "expected 2 numbers (height and width), got " + std::to_string(size_line.tokens.size()));
  }
  int size[2] = {0, 0};
  for (int i = 0; i < 2; ++i) {
    const auto value = parseIntegral(size_line.tokens[static_cast<size_t>(i)]);
    if (!value || *value <= 0) {
      throw Error(at(file, size_line.line, kBlocks[4]),
                  "not a positive integer: " + excerpt(size_line.tokens[static_cast<size_t>(i)]));
    }
    size[i] = *value;
  }
  if (data.size() > kNumBlocks) {
    throw Error(
        at(file, data[kNumBlocks].line, ""),
        "unexpected data after the image size (calib_results.txt has five blocks: polynomial, "
        "inverse polynomial, center, affine, image size)");
  }
  const int height = size[0];
  const int width = size[1];
  // OCamCalib's centre is (row, column), 0-based with pixel centres on
  // integers (the C export subtracts 1 from MATLAB's 1-based centre), the
  // same pixel convention as lookboth: cx = column, cy = row, no offset.
  std::vector<double> params = {center[1], center[0], affine[0], affine[1], affine[2]};
  params.insert(params.end(), poly.begin(), poly.end());
  params.insert(params.end(), inv_poly.begin(), inv_poly.end());
  CameraModel model =
      makeScaramuzza(static_cast<int>(poly.size()), static_cast<int>(inv_poly.size()));
  return makeCamera(std::move(model), width, height, std::move(params), at(file, 0, ""));
}

// ---------------------------------------------------------------------------
// OpenCV FileStorage (YAML or XML)

Camera loadOpenCv(const std::string& text, const std::string& file) {
  checkFileStorageStructure(text, file);
  std::string field;  // what is being read, for OpenCV's own exceptions
  try {
    cv::FileStorage storage(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!storage.isOpened())
      throw Error(at(file, 0, ""), "OpenCV could not open it as FileStorage");

    auto readSize = [&](const char* key) {
      field = key;
      const cv::FileNode node = storage[key];
      if (node.empty() || node.isNone()) {
        throw Error(at(file, 0, key),
                    "missing (OpenCV calibration files must give the image size)");
      }
      double value = 0.0;
      if (node.isInt()) {
        value = static_cast<int>(node);
      } else if (node.isReal()) {
        value = static_cast<double>(node);
      } else {
        throw Error(at(file, 0, key), "expected an integer");
      }
      if (std::floor(value) != value || std::abs(value) > 1e9) {
        throw Error(at(file, 0, key), "not an integer: " + describeNumber(value));
      }
      return static_cast<int>(value);
    };
    constexpr int kMaxMatrixSide = 64;
    auto readMatrix = [&](const char* key, bool required) {
      field = key;
      const cv::FileNode node = storage[key];
      cv::Mat matrix;
      if (node.empty() || node.isNone()) {
        if (required) throw Error(at(file, 0, key), "missing");
        return matrix;
      }
      if (!node.isMap() && !node.isSeq()) throw Error(at(file, 0, key), "expected a matrix");
      if (node.isMap()) {
        // OpenCV allocates rows x cols before it reads the data: a corrupt
        // size would ask for gigabytes. Calibration matrices are small.
        for (const char* dimension : {"rows", "cols"}) {
          const cv::FileNode n = node[dimension];
          if (!n.isInt() || static_cast<int>(n) < 1 || static_cast<int>(n) > kMaxMatrixSide) {
            throw Error(at(file, 0, std::string(key) + "." + dimension),
                        "expected an integer from 1 to " + std::to_string(kMaxMatrixSide));
          }
        }
        node >> matrix;
      } else {  // a plain list of numbers
        std::vector<double> values;
        node >> values;
        matrix = cv::Mat(values, true).reshape(1, 1);
      }
      if (matrix.empty() && required)
        throw Error(at(file, 0, key), "expected a matrix, found none");
      if (!matrix.empty()) {
        if (matrix.channels() != 1) throw Error(at(file, 0, key), "expected a one-channel matrix");
        matrix.convertTo(matrix, CV_64F);
      }
      return matrix;
    };

    const cv::Mat k = readMatrix("camera_matrix", true);
    if (k.rows != 3 || k.cols != 3) {
      throw Error(at(file, 0, "camera_matrix"),
                  "must be 3 x 3, got " + std::to_string(k.rows) + " x " + std::to_string(k.cols));
    }
    if (k.at<double>(0, 1) != 0.0) {
      throw Error(at(file, 0, "camera_matrix"),
                  "skew K[0][1] = " + describeNumber(k.at<double>(0, 1)) +
                      " is not zero; lookboth camera models have no skew");
    }
    if (k.at<double>(1, 0) != 0.0 || k.at<double>(2, 0) != 0.0 || k.at<double>(2, 1) != 0.0 ||
        k.at<double>(2, 2) != 1.0) {
      throw Error(
          at(file, 0, "camera_matrix"),
          "not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]: K[1][0], K[2][0], K[2][1] must be 0 "
          "and K[2][2] must be 1");
    }
    const cv::Mat d_matrix = readMatrix("distortion_coefficients", false);
    if (!d_matrix.empty() && d_matrix.rows != 1 && d_matrix.cols != 1) {
      throw Error(at(file, 0, "distortion_coefficients"),
                  "must be a single row or column, got " + std::to_string(d_matrix.rows) + " x " +
                      std::to_string(d_matrix.cols));
    }
    std::vector<double> d;
    if (!d_matrix.empty()) d.assign(d_matrix.begin<double>(), d_matrix.end<double>());

    // The fisheye marker: OpenCV's calibration sample writes
    // "fisheye_model: 1"; others write a distortion_model name.
    bool fisheye = false;
    field = "distortion_model";
    const cv::FileNode model_node = storage["distortion_model"];
    if (!model_node.empty() && !model_node.isNone()) {
      if (!model_node.isString()) throw Error(at(file, 0, "distortion_model"), "expected a name");
      const std::string name = static_cast<std::string>(model_node);
      if (name == "fisheye" || name == "equidistant" || name == "kannala_brandt") {
        fisheye = true;
      } else if (name != "plumb_bob" && name != "radtan" && name != "rational_polynomial" &&
                 name != "pinhole" && name != "none") {
        throw Error(at(file, 0, "distortion_model"),
                    "unknown distortion model " + excerpt(name) +
                        " (known: fisheye, equidistant, kannala_brandt, plumb_bob, radtan, "
                        "rational_polynomial, none)");
      }
    }
    field = "fisheye_model";
    const cv::FileNode fisheye_node = storage["fisheye_model"];
    if (!fisheye_node.empty() && !fisheye_node.isNone()) {
      if (!fisheye_node.isInt()) throw Error(at(file, 0, "fisheye_model"), "expected 0 or 1");
      if (static_cast<int>(fisheye_node) != 0) fisheye = true;
    }

    const int width = readSize("image_width");
    const int height = readSize("image_height");
    field.clear();

    std::vector<double> params = {k.at<double>(0, 0), k.at<double>(1, 1), k.at<double>(0, 2),
                                  k.at<double>(1, 2)};
    CameraModel model = PinholeModel{};
    const std::string count = std::to_string(d.size());
    if (fisheye) {
      if (d.size() != 4) {
        throw Error(
            at(file, 0, "distortion_coefficients"),
            "a fisheye (Kannala-Brandt) camera needs 4 coefficients k1 k2 k3 k4, got " + count);
      }
      model = KannalaBrandtModel{};
    } else if (d.size() == 12 || d.size() == 14) {
      // OpenCV's thin prism (s1..s4) and tilted sensor (tauX, tauY) terms.
      const bool extras_zero =
          std::all_of(d.begin() + 8, d.end(), [](double v) { return v == 0.0; });
      if (!extras_zero) {
        throw Error(at(file, 0, "distortion_coefficients"),
                    count +
                        " coefficients: thin prism / tilted sensor distortion is not supported "
                        "(only k1 k2 p1 p2 k3 [k4 k5 k6])");
      }
      d.resize(8);
      model = RationalPolynomialModel{};
    } else if (d.size() == 8) {
      model = RationalPolynomialModel{};
    } else if (d.size() == 5) {
      model = RadTanModel{};
    } else if (d.size() == 4) {
      throw Error(at(file, 0, "distortion_coefficients"),
                  "4 coefficients are ambiguous: add 'distortion_model: fisheye' for a fisheye "
                  "(k1 k2 k3 k4), or give 5 (k1 k2 p1 p2 k3) for plumb bob");
    } else if (!d.empty()) {
      throw Error(at(file, 0, "distortion_coefficients"),
                  "expected 0, 5, 8 or 4 (with a fisheye marker) coefficients, got " + count);
    }
    params.insert(params.end(), d.begin(), d.end());
    return makeCamera(std::move(model), width, height, std::move(params), at(file, 0, ""));
  } catch (const cv::Exception& error) {
    // OpenCV's parsers report "(<line>): <problem>"; OpenCV 4.6 puts that in
    // `func` and the parser function's name in `err`, later versions in `err`.
    for (const std::string& part : {error.err, error.func}) {
      const size_t close = part.find("): ");
      const size_t open = part.rfind('(', close);
      if (close == std::string::npos || open == std::string::npos) continue;
      if (const auto line = parseIntegral(part.substr(open + 1, close - open - 1))) {
        throw Error(at(file, *line, field), "OpenCV could not read it: " + part.substr(close + 3));
      }
    }
    throw Error(at(file, 0, field), "OpenCV could not read it: " + error.err);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& error) {
    // Not a parse error but a failure inside OpenCV's reader: an element
    // with type_id="str" makes it read a string length it never stored.
    throw Error(at(file, 0, field), std::string("OpenCV could not read it: ") + error.what());
  }
}

// ---------------------------------------------------------------------------
// CamOdoCal (VINS-Mono, VINS-Fusion): OpenCV FileStorage YAML with model_type

/// A number in a map of the file ("projection_parameters.gamma1").
double camOdoCalNumber(const cv::FileStorage& storage, const char* section, const char* key,
                       const std::string& file) {
  const std::string field = std::string(section) + "." + key;
  const cv::FileNode map = storage[section];
  if (map.empty() || map.isNone() || !map.isMap())
    throw Error(at(file, 0, section), "missing (a map of the model's parameters)");
  const cv::FileNode node = map[key];
  if (node.empty() || node.isNone()) throw Error(at(file, 0, field), "missing");
  if (!node.isReal() && !node.isInt()) throw Error(at(file, 0, field), "expected a number");
  const double value = node.isInt() ? static_cast<int>(node) : static_cast<double>(node);
  if (!std::isfinite(value)) throw Error(at(file, 0, field), "not a finite number");
  return value;
}

int camOdoCalSize(const cv::FileStorage& storage, const char* key, const std::string& file) {
  const cv::FileNode node = storage[key];
  if (node.empty() || node.isNone()) throw Error(at(file, 0, key), "missing");
  if (!node.isInt()) throw Error(at(file, 0, key), "expected an integer");
  return static_cast<int>(node);
}

Camera loadCamOdoCal(const std::string& text, const std::string& file) {
  checkFileStorageStructure(text, file);
  try {
    cv::FileStorage storage(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!storage.isOpened())
      throw Error(at(file, 0, ""), "OpenCV could not open it as FileStorage");
    const cv::FileNode type_node = storage["model_type"];
    if (!type_node.isString()) throw Error(at(file, 0, "model_type"), "expected a name");
    const std::string type = static_cast<std::string>(type_node);
    const int width = camOdoCalSize(storage, "image_width", file);
    const int height = camOdoCalSize(storage, "image_height", file);
    auto number = [&](const char* section, const char* key) {
      return camOdoCalNumber(storage, section, key, file);
    };
    CameraModel model;
    std::vector<double> params;
    if (type == "MEI") {
      model = MeiModel{};
      params = {
          number("projection_parameters", "gamma1"), number("projection_parameters", "gamma2"),
          number("projection_parameters", "u0"),     number("projection_parameters", "v0"),
          number("mirror_parameters", "xi"),         number("distortion_parameters", "k1"),
          number("distortion_parameters", "k2"),     number("distortion_parameters", "p1"),
          number("distortion_parameters", "p2")};
    } else if (type == "PINHOLE") {
      model = RadTanModel{};
      params = {number("projection_parameters", "fx"),
                number("projection_parameters", "fy"),
                number("projection_parameters", "cx"),
                number("projection_parameters", "cy"),
                number("distortion_parameters", "k1"),
                number("distortion_parameters", "k2"),
                number("distortion_parameters", "p1"),
                number("distortion_parameters", "p2"),
                0.0};  // k3: CamOdoCal's pinhole has none
    } else if (type == "KANNALA_BRANDT") {
      // CamOdoCal numbers the coefficients of theta^3 .. theta^9 k2 .. k5.
      model = KannalaBrandtModel{};
      params = {number("projection_parameters", "mu"), number("projection_parameters", "mv"),
                number("projection_parameters", "u0"), number("projection_parameters", "v0"),
                number("projection_parameters", "k2"), number("projection_parameters", "k3"),
                number("projection_parameters", "k4"), number("projection_parameters", "k5")};
    } else {
      throw Error(at(file, 0, "model_type"),
                  "CamOdoCal model " + excerpt(type) +
                      " is not supported (supported: MEI, PINHOLE, KANNALA_BRANDT; for "
                      "SCARAMUZZA give OCamCalib's calib_results.txt)");
    }
    return makeCamera(std::move(model), width, height, std::move(params),
                      at(file, 0, "projection_parameters"));
  } catch (const cv::Exception& error) {
    throw Error(at(file, 0, ""), std::string("OpenCV could not read it: ") + error.what());
  }
}

// ---------------------------------------------------------------------------
// Format detection

CameraFileFormat detectFromText(const std::string& text, const std::string& file) {
  const std::string head = trim(std::string_view(text).substr(0, 64));
  if (startsWith(head, "%YAML") || startsWith(head, "<?xml") ||
      startsWith(head, "<opencv_storage") || text.find("!!opencv-matrix") != std::string::npos) {
    // CamOdoCal writes FileStorage YAML too, named by a top-level model_type.
    for (const std::string& line : splitLines(text))
      if (startsWith(line, "model_type:")) return CameraFileFormat::kCamOdoCal;
    return CameraFileFormat::kOpenCV;
  }
  bool ocam = false;
  bool lookboth = false;
  bool kalibr = false;
  bool camera_matrix = false;
  bool ros_key = false;
  for (const std::string& raw : splitLines(text)) {
    if (startsWith(raw, "#")) {
      std::string lower = raw;
      std::transform(lower.begin(), lower.end(), lower.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (lower.find("polynomial coefficients") != std::string::npos) ocam = true;
      continue;
    }
    const size_t colon = raw.find(':');
    if (colon == std::string::npos || raw.empty() ||
        std::isspace(static_cast<unsigned char>(raw[0]))) {
      continue;
    }
    const std::string key = trim(raw.substr(0, colon));
    if (key == "lookboth_camera") lookboth = true;
    if (key == "camera_matrix") camera_matrix = true;
    if (key == "distortion_model" || key == "image_width") ros_key = true;
    if (key.size() > 3 && startsWith(key, "cam") &&
        std::all_of(key.begin() + 3, key.end(),
                    [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; })) {
      kalibr = true;
    }
  }
  if (lookboth) return CameraFileFormat::kLookboth;
  if (ocam) return CameraFileFormat::kOCamCalib;
  if (camera_matrix && ros_key) return CameraFileFormat::kRosCameraInfo;
  if (kalibr) return CameraFileFormat::kKalibr;
  throw Error(at(file, 0, ""),
              "not a camera calibration file lookboth knows (lookboth YAML, ROS camera_info YAML, "
              "Kalibr camchain, OCamCalib calib_results.txt, OpenCV FileStorage YAML/XML, "
              "CamOdoCal YAML; see doc/formats.md)");
}

}  // namespace

std::string cameraFileFormatName(CameraFileFormat format) {
  switch (format) {
    case CameraFileFormat::kAuto:
      return "auto";
    case CameraFileFormat::kLookboth:
      return "lookboth";
    case CameraFileFormat::kRosCameraInfo:
      return "ros_camera_info";
    case CameraFileFormat::kKalibr:
      return "kalibr";
    case CameraFileFormat::kOCamCalib:
      return "ocamcalib";
    case CameraFileFormat::kOpenCV:
      return "opencv";
    case CameraFileFormat::kCamOdoCal:
      return "camodocal";
  }
  return "unknown";
}

CameraFileFormat detectCameraFileFormat(const fs::path& path) {
  return detectFromText(readFile(path), path.string());
}

Camera loadCamera(const fs::path& path, CameraFileFormat format, const std::string& camera_name) {
  const std::string file = path.string();
  const std::string text = readFile(path);
  if (format == CameraFileFormat::kAuto) format = detectFromText(text, file);
  switch (format) {
    case CameraFileFormat::kLookboth:
      return guardYaml(file, [&] { return parseLookbothYaml(text, file); });
    case CameraFileFormat::kRosCameraInfo:
      return guardYaml(file, [&] { return loadRosCameraInfo(text, file); });
    case CameraFileFormat::kKalibr: {
      const std::string name = camera_name.empty() ? "cam0" : camera_name;
      return guardYaml(file, [&] { return loadKalibr(text, file, name).at(name); });
    }
    case CameraFileFormat::kOCamCalib:
      return loadOCamCalib(text, file);
    case CameraFileFormat::kOpenCV:
      return loadOpenCv(text, file);
    case CameraFileFormat::kCamOdoCal:
      return loadCamOdoCal(text, file);
    case CameraFileFormat::kAuto:
      break;
  }
  throw Error(at(file, 0, ""), "unknown camera file format");
}

std::map<std::string, Camera> loadKalibrCamchain(const fs::path& path) {
  const std::string file = path.string();
  const std::string text = readFile(path);
  return guardYaml(file, [&] { return loadKalibr(text, file, ""); });
}

void saveCamera(const Camera& camera, const fs::path& path) {
  writeFileAtomically(path, cameraToYaml(camera));
}

std::string cameraToYaml(const Camera& camera) { return writeLookbothYaml(camera); }

Camera cameraFromYaml(const std::string& yaml, const std::string& source) {
  return guardYaml(source, [&] { return parseLookbothYaml(yaml, source); });
}

mrpt::img::TCamera toMrptCamera(const Camera& camera) {
  const std::vector<double>& p = camera.params();
  mrpt::img::TCamera out;
  out.ncols = static_cast<uint32_t>(camera.width());
  out.nrows = static_cast<uint32_t>(camera.height());
  out.setIntrinsicParamsFromValues(p[0], p[1], p[2], p[3]);
  out.distortion = mrpt::img::DistortionModel::none;
  out.dist.fill(0.0);
  const CameraModel& model = camera.model();
  if (std::holds_alternative<PinholeModel>(model)) {
    // no distortion
  } else if (std::holds_alternative<RadTanModel>(model)) {
    out.setDistortionPlumbBob(p[4], p[5], p[6], p[7], p[8]);
  } else if (std::holds_alternative<RationalPolynomialModel>(model)) {
    out.setDistortionPlumbBob(p[4], p[5], p[6], p[7], p[8]);
    out.k4(p[9]);
    out.k5(p[10]);
    out.k6(p[11]);
  } else if (std::holds_alternative<KannalaBrandtModel>(model)) {
    out.setDistortionKannalaBrandt(p[4], p[5], p[6], p[7]);
  } else {
    throw Error(at("", 0, "", camera.description()),
                "MRPT's TCamera cannot hold a " + camera.modelName() +
                    " camera (only pinhole, radtan, rational_polynomial and kannala_brandt)");
  }
  return out;
}

Camera fromMrptCamera(const mrpt::img::TCamera& camera) {
  const ErrorContext context =
      at("", 0, "", camera.cameraName.empty() ? "TCamera" : camera.cameraName);
  const auto& k = camera.intrinsicParams;
  if (k(0, 1) != 0.0) {
    throw Error(context, "skew K[0][1] = " + describeNumber(k(0, 1)) +
                             " is not zero; lookboth camera models have no skew");
  }
  if (k(1, 0) != 0.0 || k(2, 0) != 0.0 || k(2, 1) != 0.0 || k(2, 2) != 1.0) {
    throw Error(context, "intrinsicParams is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  std::vector<double> params = {camera.fx(), camera.fy(), camera.cx(), camera.cy()};
  CameraModel model = PinholeModel{};
  switch (camera.distortion) {
    case mrpt::img::DistortionModel::none:
      break;
    case mrpt::img::DistortionModel::plumb_bob:
      params.insert(params.end(),
                    {camera.k1(), camera.k2(), camera.p1(), camera.p2(), camera.k3()});
      if (camera.k4() != 0.0 || camera.k5() != 0.0 || camera.k6() != 0.0) {
        model = RationalPolynomialModel{};
        params.insert(params.end(), {camera.k4(), camera.k5(), camera.k6()});
      } else {
        model = RadTanModel{};
      }
      break;
    case mrpt::img::DistortionModel::kannala_brandt:
      model = KannalaBrandtModel{};
      params.insert(params.end(), {camera.k1(), camera.k2(), camera.k3(), camera.k4()});
      break;
    default:
      throw Error(context, "unknown TCamera distortion model");
  }
  return makeCamera(std::move(model), static_cast<int>(camera.ncols),
                    static_cast<int>(camera.nrows), std::move(params), context);
}

}  // namespace lookboth
