#include "tac3d/calib/calibration_board.h"

#include <cmath>
#include <fstream>
#include <set>
#include <type_traits>

#include <yaml-cpp/yaml.h>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// A mapping of board.yaml whose keys are all required and none unknown.
class Section {
 public:
  Section(const YAML::Node& node, std::string where, const std::string& file)
      : node_(node), where_(std::move(where)), file_(file) {
    if (!node_.IsMap()) Fail(where_, "must be a mapping");
  }

  void RefuseUnknownKeys() const {
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!used_.count(key)) Fail(Join(key), "unknown key (misspelt?)");
    }
  }

  YAML::Node Required(const std::string& key) {
    used_.insert(key);
    const YAML::Node child = node_[key];
    if (!child) Fail(Join(key), "missing");
    return child;
  }

  template <typename T>
  T Scalar(const std::string& key) {
    const YAML::Node n = Required(key);
    const char* expected = std::is_same_v<T, int>      ? "must be an integer"
                           : std::is_same_v<T, double> ? "must be a number"
                                                       : "must be a string";
    if (!n.IsScalar()) Fail(Join(key), expected);
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      Fail(Join(key), expected);
    }
  }

  Eigen::Vector3d Vector3(const std::string& key) {
    const YAML::Node n = Required(key);
    if (!n.IsSequence() || n.size() != 3) Fail(Join(key), "must be a list of 3 numbers");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v(i) = Number(n[i], Join(key));
    return v;
  }

  Eigen::Matrix3d Matrix3(const std::string& key) {
    const YAML::Node n = Required(key);
    if (!n.IsSequence() || n.size() != 3) Fail(Join(key), "must be 3 rows of 3 numbers");
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) {
      if (!n[r].IsSequence() || n[r].size() != 3) Fail(Join(key), "must be 3 rows of 3 numbers");
      for (int c = 0; c < 3; ++c) m(r, c) = Number(n[r][c], Join(key));
    }
    return m;
  }

  Section Child(const std::string& key) { return Section(Required(key), Join(key), file_); }

  [[noreturn]] void Fail(const std::string& where, const std::string& what) const {
    throw Error(fmt::format("{}: {}: {}", file_, where, what));
  }
  std::string Join(const std::string& key) const {
    return where_.empty() ? key : where_ + "." + key;
  }

 private:
  double Number(const YAML::Node& n, const std::string& where) const {
    try {
      if (n.IsScalar()) return n.as<double>();
    } catch (const YAML::Exception&) {
    }
    Fail(where, "must be a number");
  }

  YAML::Node node_;
  std::string where_;
  const std::string& file_;
  std::set<std::string> used_;
};

}  // namespace

void CalibrationBoard::Validate() const {
  const OptionCheck require("calibration board");
  require(rows >= 3 && rows <= kMaxDotsPerSide, "rows", "in [3, 1000]", rows);
  require(cols >= 3 && cols <= kMaxDotsPerSide, "cols", "in [3, 1000]", cols);
  require(spacing_mm > 0 && spacing_mm <= SensorLimits::kMaxLengthMm, "spacing_mm", "> 0 and <= 1000 mm",
          spacing_mm);
  require(dot_diameter_mm > 0 && dot_diameter_mm < NearestDotDistance(), "dot_diameter_mm",
          "> 0 and smaller than the distance between neighbouring dots", dot_diameter_mm);
}

std::vector<Eigen::Vector3d> CalibrationBoard::DotCenters() const {
  std::vector<Eigen::Vector3d> centers;
  centers.reserve(rows * cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int x = layout == Layout::kSymmetric ? c : 2 * c + r % 2;
      centers.emplace_back(x * spacing_mm, r * spacing_mm, 0.0);
    }
  }
  return centers;
}

Eigen::Vector3d CalibrationBoard::GridCenter() const {
  const int width = layout == Layout::kSymmetric ? cols - 1 : 2 * (cols - 1) + 1;
  return {0.5 * width * spacing_mm, 0.5 * (rows - 1) * spacing_mm, 0.0};
}

double CalibrationBoard::NearestDotDistance() const {
  return layout == Layout::kSymmetric ? spacing_mm : std::sqrt(2.0) * spacing_mm;
}

Rigid3 CalibrationBoard::ReferenceSensorFromBoard() const {
  const Eigen::Vector3d c = GridCenter();
  Rigid3 pose = Rigid3::Identity();
  pose.translation() = Eigen::Vector3d(-c.x(), -c.y(), 0.0);
  return pose;
}

CalibrationBoardFile LoadCalibrationBoardFile(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "board file");
  CalibrationBoardFile file;
  Section top(root, "", path);
  {
    Section b = top.Child("board");
    const std::string layout = b.Scalar<std::string>("layout");
    if (layout == "symmetric") {
      file.board.layout = CalibrationBoard::Layout::kSymmetric;
    } else if (layout == "asymmetric") {
      file.board.layout = CalibrationBoard::Layout::kAsymmetric;
    } else {
      b.Fail(b.Join("layout"), fmt::format("'{}' must be symmetric or asymmetric", layout));
    }
    file.board.rows = b.Scalar<int>("rows");
    file.board.cols = b.Scalar<int>("cols");
    file.board.spacing_mm = b.Scalar<double>("spacing_mm");
    file.board.dot_diameter_mm = b.Scalar<double>("dot_diameter_mm");
    b.RefuseUnknownKeys();
  }
  {
    Section r = top.Child("reference");
    file.reference_image = r.Scalar<std::string>("image");
    Section pose = r.Child("sensor_from_board");
    file.sensor_from_board.translation() = pose.Vector3("position_mm");
    const Eigen::Matrix3d rotation = pose.Matrix3("rotation");
    if ((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
        std::abs(rotation.determinant() - 1.0) > 1e-6) {
      pose.Fail(pose.Join("rotation"), "is not a rotation matrix");
    }
    file.sensor_from_board.linear() = rotation;
    pose.RefuseUnknownKeys();
    r.RefuseUnknownKeys();
  }
  top.RefuseUnknownKeys();
  try {
    file.board.Validate();
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", path, e.what()));
  }
  return file;
}

void SaveCalibrationBoardFile(const CalibrationBoardFile& file, const std::string& path) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // enough digits to read back the same doubles
  out << YAML::Comment("tac3d calibration board: mm; the pose of the board in the reference image");
  out << YAML::BeginMap;
  out << YAML::Key << "board" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "layout" << YAML::Value
      << (file.board.layout == CalibrationBoard::Layout::kSymmetric ? "symmetric" : "asymmetric");
  out << YAML::Key << "rows" << YAML::Value << file.board.rows;
  out << YAML::Key << "cols" << YAML::Value << file.board.cols;
  out << YAML::Key << "spacing_mm" << YAML::Value << file.board.spacing_mm;
  out << YAML::Key << "dot_diameter_mm" << YAML::Value << file.board.dot_diameter_mm;
  out << YAML::EndMap;
  out << YAML::Key << "reference" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "image" << YAML::Value << file.reference_image;
  out << YAML::Key << "sensor_from_board" << YAML::Value << YAML::BeginMap;
  const Eigen::Vector3d t = file.sensor_from_board.translation();
  out << YAML::Key << "position_mm" << YAML::Value << YAML::Flow << YAML::BeginSeq << t.x()
      << t.y() << t.z() << YAML::EndSeq;
  out << YAML::Key << "rotation" << YAML::Value << YAML::BeginSeq;
  const Eigen::Matrix3d r = file.sensor_from_board.linear();
  for (int i = 0; i < 3; ++i) {
    out << YAML::Flow << YAML::BeginSeq << r(i, 0) << r(i, 1) << r(i, 2) << YAML::EndSeq;
  }
  out << YAML::EndSeq << YAML::EndMap << YAML::EndMap << YAML::EndMap;
  std::ofstream stream(path);
  stream << out.c_str() << "\n";
  if (!stream) throw Error(fmt::format("cannot write board file '{}'", path));
}

}  // namespace tac3d
