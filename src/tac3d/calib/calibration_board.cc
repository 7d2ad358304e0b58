#include "tac3d/calib/calibration_board.h"

#include <cmath>
#include <fstream>

#include <yaml-cpp/yaml.h>

#include "tac3d/sensor/sensor_config.h"
#include "tac3d/sensor/yaml_reader.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {

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
  YamlReader top(root, "", &path);
  {
    YamlReader b = top.Child("board");
    const std::string layout = b.String("layout");
    if (layout == "symmetric") {
      file.board.layout = CalibrationBoard::Layout::kSymmetric;
    } else if (layout == "asymmetric") {
      file.board.layout = CalibrationBoard::Layout::kAsymmetric;
    } else {
      b.FailAt(b.Required("layout"), b.Join("layout"),
               fmt::format("'{}' must be symmetric or asymmetric", layout));
    }
    file.board.rows = b.Int("rows");
    file.board.cols = b.Int("cols");
    file.board.spacing_mm = b.Double("spacing_mm");
    file.board.dot_diameter_mm = b.Double("dot_diameter_mm");
  }
  {
    YamlReader r = top.Child("reference");
    file.reference_image = r.String("image");
    YamlReader pose = r.Child("sensor_from_board");
    file.sensor_from_board.translation() = pose.Vector<3>("position_mm");
    const Eigen::Matrix3d rotation = pose.Matrix3("rotation");
    if ((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
        std::abs(rotation.determinant() - 1.0) > 1e-6) {
      pose.FailAt(pose.Required("rotation"), pose.Join("rotation"), "is not a rotation matrix");
    }
    file.sensor_from_board.linear() = rotation;
  }
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
  WriteTextFileAtomically(path, std::string(out.c_str()) + "\n");
}

}  // namespace tac3d
