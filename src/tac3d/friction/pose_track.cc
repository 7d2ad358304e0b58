#include "tac3d/friction/pose_track.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d::friction {
namespace {

constexpr const char* kHeader = "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz";
// A pose a line, ~60 bytes: room for four million poses (11 hours at 100 Hz), while /dev/zero
// or a wrong file fails at once instead of filling memory.
constexpr std::size_t kMaxPoseCsvBytes = 256u << 20;

std::string Where(const std::string& source, int line) {
  return line > 0 ? fmt::format("{}:{}", source, line) : source;
}

}  // namespace

PoseTrack::PoseTrack(std::vector<TimedPose> poses, std::string source)
    : poses_(std::move(poses)), source_(std::move(source)) {
  if (poses_.empty()) throw Error(fmt::format("poses '{}': no pose", source_));
  for (size_t i = 0; i < poses_.size(); ++i) {
    if (!std::isfinite(poses_[i].t_s)) {
      throw Error(
          fmt::format("{}: t_s = {} is not finite", Where(source_, poses_[i].line), poses_[i].t_s));
    }
    if (i > 0 && !(poses_[i].t_s > poses_[i - 1].t_s)) {
      throw Error(fmt::format("{}: t_s = {} goes back: it must be after the previous pose's {}",
                              Where(source_, poses_[i].line),
                              poses_[i].t_s,
                              poses_[i - 1].t_s));
    }
  }
}

PoseTrack PoseTrack::ReadCsv(const std::string& path, double unit_tolerance) {
  std::istringstream in(ReadFileCapped(path, kMaxPoseCsvBytes, "pose CSV"));
  std::vector<TimedPose> poses;
  std::string line;
  int line_number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_number;
    std::string compact;
    std::remove_copy_if(line.begin(), line.end(), std::back_inserter(compact), [](unsigned char c) {
      return std::isspace(c) != 0;
    });
    if (compact.empty() || compact[0] == '#') continue;
    if (!header) {
      if (compact != kHeader) {
        throw Error(fmt::format("{}:{}: the header must be {}", path, line_number, kHeader));
      }
      header = true;
      continue;
    }
    std::stringstream fields(compact);
    std::string field;
    double v[8];
    int n = 0;
    while (std::getline(fields, field, ',')) {
      char* end = nullptr;
      const double value = std::strtod(field.c_str(), &end);
      if (n >= 8 || field.empty() || *end != '\0' || !std::isfinite(value)) {
        throw Error(
            fmt::format("{}:{}: expected 8 finite numbers ({})", path, line_number, kHeader));
      }
      v[n++] = value;
    }
    if (n != 8) {
      throw Error(fmt::format(
          "{}:{}: expected 8 finite numbers ({}), got {}", path, line_number, kHeader, n));
    }
    Eigen::Quaterniond q(v[4], v[5], v[6], v[7]);
    const double norm = q.norm();
    if (!(std::abs(norm - 1.0) <= unit_tolerance)) {
      throw Error(
          fmt::format("{}:{}: quaternion (qw, qx, qy, qz) = ({}, {}, {}, {}) has norm {}: not unit "
                      "length within {}",
                      path,
                      line_number,
                      v[4],
                      v[5],
                      v[6],
                      v[7],
                      norm,
                      unit_tolerance));
    }
    if (!poses.empty() && !(v[0] > poses.back().t_s)) {
      throw Error(fmt::format("{}:{}: t_s = {} goes back: it must be after {} (line {})",
                              path,
                              line_number,
                              v[0],
                              poses.back().t_s,
                              poses.back().line));
    }
    TimedPose pose;
    pose.t_s = v[0];
    pose.world_from_sensor.linear() = q.normalized().toRotationMatrix();
    pose.world_from_sensor.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.line = line_number;
    poses.push_back(pose);
  }
  if (!header)
    throw Error(fmt::format("pose CSV '{}' is empty: the header {} is missing", path, kHeader));
  if (poses.empty()) throw Error(fmt::format("pose CSV '{}' has a header but no pose", path));
  return PoseTrack(std::move(poses), path);
}

Rigid3 PoseTrack::At(double t_s) const {
  if (!(t_s >= begin_s() && t_s <= end_s())) {
    throw Error(
        fmt::format("poses '{}' (lines {}-{}) cover t = {} .. {} s: they do not cover the frame "
                    "time {} s",
                    source_,
                    poses_.front().line,
                    poses_.back().line,
                    begin_s(),
                    end_s(),
                    t_s));
  }
  const auto next = std::upper_bound(
      poses_.begin(), poses_.end(), t_s, [](double t, const TimedPose& p) { return t < p.t_s; });
  if (next == poses_.end()) return poses_.back().world_from_sensor;
  const TimedPose& b = *next;
  const TimedPose& a = *(next - 1);
  return InterpolatePose(a.world_from_sensor, b.world_from_sensor, (t_s - a.t_s) / (b.t_s - a.t_s));
}

}  // namespace tac3d::friction
