#include "tac3d/dataset/twin_dataset.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/util/error.h"
#include "tac3d/imagefile/image_decode.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

constexpr char kFormat[] = "tac3d-twin-dataset";
constexpr int kVersion = 1;
constexpr char kSurfaceMagic[8] = {'T', 'A', 'C', '3', 'D', 'S', 'R', 'F'};

std::string StepName(int step) { return fmt::format("{:06d}", step); }

// A step's JSON holds a few thousand numbers (~100 kB); far more is not a step.
constexpr std::size_t kMaxJsonFileBytes = std::size_t{64} << 20;

nlohmann::json ReadJson(const std::string& path) {
  const std::string text = ReadFileCapped(path, kMaxJsonFileBytes, "dataset file");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("'{}' is not valid JSON: {}", path, e.what()));
  }
}

nlohmann::json ToJson(const std::vector<Eigen::Vector3d>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (const Eigen::Vector3d& p : v) a.push_back({p.x(), p.y(), p.z()});
  return a;
}

Eigen::Vector3d Vec3(const nlohmann::json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

std::vector<Eigen::Vector3d> Vec3s(const nlohmann::json& j) {
  std::vector<Eigen::Vector3d> v;
  v.reserve(j.size());
  for (const nlohmann::json& p : j) v.push_back(Vec3(p));
  return v;
}

void WriteSurface(const std::string& path, const SurfaceTractions& s) {
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    const std::uint32_t version = kVersion;
    const std::uint64_t n = s.positions_mm.size();
    out.write(kSurfaceMagic, sizeof(kSurfaceMagic));
    out.write(reinterpret_cast<const char*>(&version), sizeof(version));
    out.write(reinterpret_cast<const char*>(&n), sizeof(n));
    for (size_t i = 0; i < n; ++i) {
      out.write(reinterpret_cast<const char*>(s.positions_mm[i].data()), 3 * sizeof(double));
      out.write(reinterpret_cast<const char*>(s.tractions_mpa[i].data()), 3 * sizeof(double));
    }
    out.write(reinterpret_cast<const char*>(s.states.data()), static_cast<std::streamsize>(n));
    out.flush();
    if (!out) throw Error(fmt::format("cannot write '{}'", tmp));
  });
}

SurfaceTractions ReadSurface(const std::string& path) {
  RequireRegularFile(path, "surface-traction file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("cannot open '{}'", path));
  char magic[8];
  std::uint32_t version = 0;
  std::uint64_t n = 0;
  in.read(magic, sizeof(magic));
  in.read(reinterpret_cast<char*>(&version), sizeof(version));
  in.read(reinterpret_cast<char*>(&n), sizeof(n));
  if (!in || std::memcmp(magic, kSurfaceMagic, sizeof(magic)) != 0 || version != kVersion) {
    throw Error(fmt::format("'{}' is not a tac3d surface-traction file (version {})", path, kVersion));
  }
  const std::uintmax_t expected = 20 + n * (6 * sizeof(double) + 1);
  if (fs::file_size(path) != expected) {
    throw Error(fmt::format("'{}' has {} bytes, {} nodes need {} (truncated?)", path, fs::file_size(path), n, expected));
  }
  SurfaceTractions s;
  s.positions_mm.resize(n);
  s.tractions_mpa.resize(n);
  s.states.resize(n);
  for (size_t i = 0; i < n; ++i) {
    in.read(reinterpret_cast<char*>(s.positions_mm[i].data()), 3 * sizeof(double));
    in.read(reinterpret_cast<char*>(s.tractions_mpa[i].data()), 3 * sizeof(double));
  }
  in.read(reinterpret_cast<char*>(s.states.data()), static_cast<std::streamsize>(n));
  for (ContactState state : s.states) {
    if (static_cast<int>(state) > 2) throw Error(fmt::format("'{}': a contact state is not 0, 1 or 2", path));
  }
  return s;
}

}  // namespace

TwinDatasetWriter::TwinDatasetWriter(const std::string& folder, const nlohmann::json& header) : folder_(folder) {
  CheckOutputFolder(folder, "dataset folder");
  std::error_code ec;
  if (fs::exists(folder) && !fs::is_empty(folder, ec)) {
    throw Error(fmt::format("dataset folder '{}' is not empty (choose a new one, or remove it)", folder));
  }
  for (const char* sub : {"", "/steps", "/images", "/surface"}) {
    fs::create_directories(folder + sub, ec);
    if (ec) throw Error(fmt::format("cannot create '{}{}': {}", folder, sub, ec.message()));
  }
  header_ = header;
  header_["format"] = kFormat;
  header_["version"] = kVersion;
  WriteTextFileAtomically(folder + "/dataset.json", header_.dump(2) + "\n");
}

void TwinDatasetWriter::UpdateHeader(const nlohmann::json& keys) {
  for (const auto& [key, value] : keys.items()) header_[key] = value;
  WriteTextFileAtomically(folder_ + "/dataset.json", header_.dump(2) + "\n");
}

void TwinDatasetWriter::Write(const TwinStep& step) {
  const size_t n = step.marker_positions_mm.size();
  if (step.marker_forces_n.size() != n || step.marker_contact.size() != n || step.marker_slip.size() != n) {
    throw Error(fmt::format("dataset step {}: marker arrays differ in length", step.index));
  }
  if (markers_ >= 0 && static_cast<int>(n) != markers_) {
    throw Error(fmt::format("dataset step {}: {} markers, earlier steps had {}", step.index, n, markers_));
  }
  const SurfaceTractions& s = step.surface;
  if (s.tractions_mpa.size() != s.positions_mm.size() || s.states.size() != s.positions_mm.size()) {
    throw Error(fmt::format("dataset step {}: surface arrays differ in length", step.index));
  }
  markers_ = static_cast<int>(n);
  const std::string name = StepName(step.index);
  nlohmann::json j;
  j["index"] = step.index;
  j["t_s"] = step.t_s;
  const Eigen::Quaterniond q(step.world_from_sensor.linear());
  j["world_from_sensor"] = {{"position_mm", ToJson({step.world_from_sensor.translation()})[0]},
                            {"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}}};
  j["total_force_n"] = ToJson({step.total_force_n})[0];
  j["total_moment_nmm"] = ToJson({step.total_moment_nmm})[0];
  j["markers"] = {{"positions_mm", ToJson(step.marker_positions_mm)},
                  {"forces_n", ToJson(step.marker_forces_n)},
                  {"contact", step.marker_contact},
                  {"slip", step.marker_slip}};
  j["solver"] = step.solver;
  if (!step.conditions.is_null()) j["conditions"] = step.conditions;
  j["image"] = nullptr;
  j["surface"] = nullptr;
  if (!step.image.empty()) {
    const std::string rel = "images/" + name + ".png";
    std::vector<unsigned char> png;
    // Fast compression: a 500-step scene writes 500 images.
    if (!cv::imencode(".png", step.image, png, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
      throw Error(fmt::format("dataset step {}: the image does not encode as PNG", step.index));
    }
    WriteTextFileAtomically(folder_ + "/" + rel, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    j["image"] = rel;
  }
  if (!s.positions_mm.empty()) {
    const std::string rel = "surface/" + name + ".bin";
    WriteSurface(folder_ + "/" + rel, s);
    j["surface"] = rel;
  }
  WriteTextFileAtomically(folder_ + "/steps/" + name + ".json", j.dump() + "\n");
}

TwinDatasetReader::TwinDatasetReader(const std::string& folder) : folder_(folder) {
  header_ = ReadJson(folder + "/dataset.json");
  if (header_.value("format", "") != kFormat) {
    throw Error(fmt::format("'{}/dataset.json' is not a tac3d twin dataset", folder));
  }
  if (header_.value("version", 0) != kVersion) {
    throw Error(fmt::format("'{}': dataset version {} (this build reads {})", folder, header_.value("version", 0), kVersion));
  }
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder + "/steps", ec)) {
    const fs::path p = e.path();
    if (p.extension() != ".json") continue;  // *.json.tmp: a step cut short
    try {
      steps_.push_back(std::stoi(p.stem().string()));
    } catch (const std::exception&) {
      // Not a step file: ignore.
    }
  }
  std::sort(steps_.begin(), steps_.end());
}

std::string TwinDatasetReader::ImagePath(int step) const { return folder_ + "/images/" + StepName(step) + ".png"; }

TwinStep TwinDatasetReader::Read(int step, bool with_surface) const {
  const std::string path = folder_ + "/steps/" + StepName(step) + ".json";
  const nlohmann::json j = ReadJson(path);
  TwinStep s;
  try {
    s.index = j.at("index").get<int>();
    s.t_s = j.at("t_s").get<double>();
    const nlohmann::json& pose = j.at("world_from_sensor");
    const nlohmann::json& q = pose.at("quaternion_wxyz");
    s.world_from_sensor.linear() =
        Eigen::Quaterniond(q.at(0).get<double>(), q.at(1).get<double>(), q.at(2).get<double>(), q.at(3).get<double>())
            .normalized()
            .toRotationMatrix();
    s.world_from_sensor.translation() = Vec3(pose.at("position_mm"));
    s.total_force_n = Vec3(j.at("total_force_n"));
    s.total_moment_nmm = Vec3(j.at("total_moment_nmm"));
    const nlohmann::json& m = j.at("markers");
    s.marker_positions_mm = Vec3s(m.at("positions_mm"));
    s.marker_forces_n = Vec3s(m.at("forces_n"));
    s.marker_contact = m.at("contact").get<std::vector<std::uint8_t>>();
    s.marker_slip = m.at("slip").get<std::vector<std::uint8_t>>();
    s.solver = j.at("solver");
    if (j.contains("conditions")) s.conditions = j.at("conditions");
    if (!j.at("image").is_null()) {
      const std::string image = folder_ + "/" + j.at("image").get<std::string>();
      s.image = cv::imdecode(ReadImageFileBytes(image), cv::IMREAD_GRAYSCALE);
      if (s.image.empty()) throw Error(fmt::format("'{}': its image does not decode", path));
    }
    if (with_surface && !j.at("surface").is_null()) {
      s.surface = ReadSurface(folder_ + "/" + j.at("surface").get<std::string>());
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("'{}' is malformed: {}", path, e.what()));
  }
  return s;
}

namespace {

class TwinDatasetSource : public FrameSource {
 public:
  explicit TwinDatasetSource(const std::string& folder) : folder_(folder), reader_(folder) {
    if (reader_.steps().empty()) throw Error(fmt::format("twin dataset '{}' has no step", folder));
  }
  ReadStatus Read(Frame& frame) override {
    if (next_ >= reader_.steps().size()) {
      last_error_ = fmt::format("{}: all {} steps read", folder_, reader_.steps().size());
      return ReadStatus::kEnd;
    }
    const int step = reader_.steps()[next_];
    frame.index = static_cast<std::int64_t>(next_++);
    try {
      const TwinStep s = reader_.Read(step);
      frame.timestamp_s = s.t_s;
      frame.image = s.image;
    } catch (const Error& e) {
      last_error_ = e.what();
      return ReadStatus::kBadFrame;
    }
    if (frame.image.empty()) {
      last_error_ = fmt::format("{}: step {} has no image", folder_, step);
      return ReadStatus::kBadFrame;
    }
    last_error_.clear();
    return ReadStatus::kOk;
  }
  std::string Describe() const override {
    return fmt::format("twin dataset {} ({} steps)", folder_, reader_.steps().size());
  }

 private:
  std::string folder_;
  TwinDatasetReader reader_;
  size_t next_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> OpenTwinDataset(const std::string& folder) {
  return std::make_unique<TwinDatasetSource>(folder);
}

}  // namespace tac3d
