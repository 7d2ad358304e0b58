#include "view_data.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tac3d/friction/friction_output.h"
#include "tac3d/util/error.h"
#include "tac3d/util/json_number.h"

namespace tac3d::cli {
namespace {

// The N of "/api/<what>/N" (a query dropped), or nullopt when the target is not of that form.
std::optional<long> IndexIn(const std::string& target, const std::string& what) {
  const std::string prefix = "/api/" + what + "/";
  if (target.rfind(prefix, 0) != 0) return std::nullopt;
  const std::string number = target.substr(prefix.size(), target.find_first_of("?#") - prefix.size());
  size_t used = 0;
  long index = -1;
  try {
    index = std::stol(number, &used);
  } catch (const std::exception&) {
  }
  if (number.empty() || used != number.size() || index < 0) {
    throw Error(fmt::format("{}: '{}' is not a frame index", target, number));
  }
  return index;
}

nlohmann::json Xyz(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

void ViewData::LoadFrames(runtime::SensorStream& stream, const std::string& source, int image_width) {
  source_ = source;
  const std::atomic<bool> stop{false};
  stream.Start({.epoch = std::chrono::steady_clock::now(), .common = false});
  std::vector<ImageMarker> markers;
  for (;;) {
    runtime::ProducedFrame out;
    const runtime::Produced produced = stream.Next(stop, out);
    if (produced == runtime::Produced::kEnd) break;
    if (produced == runtime::Produced::kSkipped) continue;
    frames_.push_back(*out.frame);
    const bool has_image = out.image != nullptr && !out.image->empty();
    // A pipeline's stream gives its tracker's markers (a dataset's), a recording none.
    markers.clear();
    if (has_image && out.markers != nullptr) ImageMarkersOf(*out.markers, markers);
    images_.push_back(
        has_image ? ImageToJson(out.frame->sn, out.frame->index, *out.image, image_width, markers) : "");
  }
  const runtime::StreamEnd end = stream.End(frames());
  if (!end.failure.empty()) throw Error(end.failure);
  if (!end.warning.empty()) std::fprintf(stderr, "tac3d: warning: %s\n", end.warning.c_str());
}

void ViewData::LoadFrictionMap(const std::string& dir_or_ply) {
  const std::string path =
      std::filesystem::is_directory(dir_or_ply) ? dir_or_ply + "/map.ply" : dir_or_ply;
  const TriangleMesh mesh = ReadPly(path);
  const auto mu = mesh.vertex_properties.find("mu");
  if (mu == mesh.vertex_properties.end()) throw Error(fmt::format("{}: no per-vertex 'mu'", path));
  const auto confidence = mesh.vertex_properties.find("confidence");
  nlohmann::json j = {{"vertices", nlohmann::json::array()},
                      {"triangles", nlohmann::json::array()},
                      {"mu", nlohmann::json::array()},
                      {"confidence", nlohmann::json::array()},
                      {"colors", nlohmann::json::array()}};
  std::array<int, 4> bands = {0, 0, 0, 0};
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) j["vertices"].push_back(mesh.vertices[i][k]);
    const double m = mu->second[i];
    j["mu"].push_back(FiniteOrNull(m));
    j["confidence"].push_back(confidence == mesh.vertex_properties.end() ? 0.0 : confidence->second[i]);
    const friction::FrictionBand band = friction::BandOf(m);
    ++bands[static_cast<int>(band)];
    for (const std::uint8_t c : friction::BandColorRgb(band)) j["colors"].push_back(c);
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) j["triangles"].push_back(t[k]);
  }
  j["bands"] = {{"unknown", bands[0]}, {"low", bands[1]}, {"medium", bands[2]}, {"high", bands[3]}};
  j["path"] = path;
  friction_json_ = j.dump();
}

std::optional<WebReply> ViewData::Handle(const std::string& target) const {
  if (target == "/api/frames" || target.rfind("/api/frames?", 0) == 0) {
    nlohmann::json j = {{"sn", frames_.empty() ? "" : frames_.front().sn},
                        {"source", source_},
                        {"count", frames_.size()},
                        {"t", nlohmann::json::array()},
                        {"F", nlohmann::json::array()},
                        {"M", nlohmann::json::array()},
                        {"images", std::count_if(images_.begin(), images_.end(),
                                                 [](const std::string& s) { return !s.empty(); })}};
    for (const TactileFrame& f : frames_) {
      j["t"].push_back(f.timestamp_s);
      j["F"].push_back(Xyz(f.resultant_force_n));
      j["M"].push_back(Xyz(f.resultant_moment_nmm));
    }
    return WebReply{.body = j.dump()};
  }
  if (const std::optional<long> i = IndexIn(target, "frame")) {
    if (*i >= frames()) return std::nullopt;
    return WebReply{.body = FrameToJson(frames_[*i], 0.0)};
  }
  if (const std::optional<long> i = IndexIn(target, "image")) {
    if (*i >= frames() || images_[*i].empty()) return std::nullopt;
    return WebReply{.body = images_[*i]};
  }
  if (target == "/api/friction-map" && !friction_json_.empty()) return WebReply{.body = friction_json_};
  return std::nullopt;
}

}  // namespace tac3d::cli
