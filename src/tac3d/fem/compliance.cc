#include "tac3d/fem/compliance.h"

#include <unistd.h>

#include <bit>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "tac3d/util/error.h"

namespace tac3d::fem {
namespace {

static_assert(std::endian::native == std::endian::little, "the cache format is little-endian");

// Bump whenever a change to the mesh, the element or the loads changes H: it is part of the
// cache key, so models cached by older code are rebuilt.
constexpr int kFemModelRevision = 1;
constexpr char kMagic[8] = {'T', 'A', 'C', '3', 'D', 'F', 'E', 'M'};
constexpr std::uint32_t kFormatVersion = 1;

std::uint64_t Fnv1a(const void* data, size_t size, std::uint64_t hash = 14695981039346656037ULL) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 1099511628211ULL;
  }
  return hash;
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// Appends a trivially copyable value's bytes.
template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Reads sequentially from a byte buffer, throwing on truncation.
class Reader {
 public:
  Reader(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path) {}

  template <typename T>
  T Get(const char* what) {
    T value;
    std::memcpy(&value, Take(sizeof(T), what), sizeof(T));
    return value;
  }
  const char* Take(size_t size, const char* what) {
    if (size > bytes_.size() - offset_) {
      throw Error(fmt::format("{}: truncated while reading {} ({} bytes at offset {}, file has {})",
                              path_,
                              what,
                              size,
                              offset_,
                              bytes_.size()));
    }
    const char* p = bytes_.data() + offset_;
    offset_ += size;
    return p;
  }
  size_t offset() const { return offset_; }

 private:
  const std::string& bytes_;
  const std::string& path_;
  size_t offset_ = 0;
};

ComplianceProvenance ProvenanceFromJson(const nlohmann::json& json) {
  ComplianceProvenance p;
  p.num_nodes = json.at("num_nodes").get<int>();
  p.num_elements = json.at("num_elements").get<int>();
  p.num_free_dofs = json.at("num_free_dofs").get<int>();
  p.assembly_s = json.at("assembly_s").get<double>();
  p.factorization_s = json.at("factorization_s").get<double>();
  p.solves_s = json.at("solves_s").get<double>();
  p.build_s = json.at("build_s").get<double>();
  p.built_utc = json.at("built_utc").get<std::string>();
  p.code_version = json.at("code_version").get<std::string>();
  return p;
}

}  // namespace

nlohmann::json ToJson(const ComplianceProvenance& p) {
  return {{"num_nodes", p.num_nodes},
          {"num_elements", p.num_elements},
          {"num_free_dofs", p.num_free_dofs},
          {"assembly_s", p.assembly_s},
          {"factorization_s", p.factorization_s},
          {"solves_s", p.solves_s},
          {"build_s", p.build_s},
          {"built_utc", p.built_utc},
          {"code_version", p.code_version}};
}

std::string FemCodeVersion() {
  return fmt::format("tac3d {}, fem model r{}", TAC3D_VERSION_STRING, kFemModelRevision);
}

ComplianceModel CalcComplianceModel(const BodyModel& model, bool show_progress) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::SparseMatrix<double> readout =
      model.CalcPointInterpolation(model.marker_positions());
  const Eigen::SparseMatrix<double> loads = model.CalcMarkerPatchLoads();
  ComplianceModel result;
  result.options = model.options();
  result.marker_positions = model.marker_positions();
  result.h = model.solver().CalcResponse(readout, loads, show_progress);
  const ElasticSolverSummary& summary = model.solver().summary();
  ComplianceProvenance& p = result.provenance;
  p.num_nodes = model.mesh().num_nodes();
  p.num_elements = model.mesh().num_elements();
  p.num_free_dofs = summary.num_free_dofs;
  p.assembly_s = summary.assembly_s;
  p.factorization_s = summary.factorization_s;
  p.solves_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  p.build_s = p.assembly_s + p.factorization_s + p.solves_s;
  p.built_utc = UtcNow();
  p.code_version = FemCodeVersion();
  return result;
}

ComplianceModel CalcComplianceModel(const BodyModelOptions& options, bool show_progress) {
  const auto start = std::chrono::steady_clock::now();
  const BodyModel model(options, show_progress);
  ComplianceModel result = CalcComplianceModel(model, show_progress);
  // Meshing and point location count too.
  result.provenance.build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::uint64_t CalcComplianceCacheKey(const BodyModelOptions& options) {
  // nlohmann::json orders keys, so the dump is canonical; doubles print round-trip exact.
  const std::string text = ToJson(options).dump() + "|" + FemCodeVersion();
  return Fnv1a(text.data(), text.size());
}

void SaveComplianceModel(const ComplianceModel& model, const std::string& path) {
  const std::string json =
      nlohmann::json{{"options", ToJson(model.options)}, {"provenance", ToJson(model.provenance)}}
          .dump();
  std::string body;  // everything after the magic, which the checksum covers
  Put(&body, kFormatVersion);
  Put(&body, CalcComplianceCacheKey(model.options));
  Put(&body, static_cast<std::uint64_t>(json.size()));
  body += json;
  Put(&body, static_cast<std::uint64_t>(model.h.rows()));
  Put(&body, static_cast<std::uint64_t>(model.h.cols()));
  body.append(reinterpret_cast<const char*>(model.h.data()), model.h.size() * sizeof(double));
  const std::uint64_t checksum = Fnv1a(body.data(), body.size());

  const std::string temporary = fmt::format("{}.tmp{}", path, getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(kMagic, sizeof(kMagic));
    out.write(body.data(), static_cast<std::streamsize>(body.size()));
    out.write(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
    if (!out) throw Error(fmt::format("cannot write the compliance model to {}", temporary));
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw Error(fmt::format("cannot rename {} to {}", temporary, path));
  }
}

namespace {

struct CacheFile {
  std::uint64_t key = 0;  // as stored
  ComplianceModel model;
};

// Reads and checks a file's structure and checksum; the key is returned, not judged.
CacheFile ReadCacheFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open", path));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Reader reader(bytes, path);
  if (std::memcmp(reader.Take(sizeof(kMagic), "the magic"), kMagic, sizeof(kMagic)) != 0) {
    throw Error(fmt::format("{}: not a tac3d compliance model (wrong magic)", path));
  }
  const size_t body_begin = reader.offset();
  const auto version = reader.Get<std::uint32_t>("the format version");
  if (version != kFormatVersion) {
    throw Error(fmt::format("{}: format version {}, expected {}", path, version, kFormatVersion));
  }
  const auto key = reader.Get<std::uint64_t>("the key");
  const auto json_size = reader.Get<std::uint64_t>("the JSON length");
  const char* json_text = reader.Take(json_size, "the JSON header");
  const auto rows = reader.Get<std::uint64_t>("the row count");
  const auto cols = reader.Get<std::uint64_t>("the column count");
  if (rows > (1u << 20) || cols > (1u << 20)) {
    throw Error(fmt::format("{}: implausible matrix size {} x {}", path, rows, cols));
  }
  const char* data = reader.Take(rows * cols * sizeof(double), "the matrix");
  const size_t body_end = reader.offset();
  const auto checksum = reader.Get<std::uint64_t>("the checksum");
  if (reader.offset() != bytes.size()) {
    throw Error(
        fmt::format("{}: {} bytes after the checksum", path, bytes.size() - reader.offset()));
  }
  if (Fnv1a(bytes.data() + body_begin, body_end - body_begin) != checksum) {
    throw Error(fmt::format("{}: checksum mismatch (the file is corrupt)", path));
  }

  CacheFile file;
  file.key = key;
  ComplianceModel& model = file.model;
  try {
    const nlohmann::json header = nlohmann::json::parse(json_text, json_text + json_size);
    model.options = BodyModelOptionsFromJson(header.at("options"));
    model.provenance = ProvenanceFromJson(header.at("provenance"));
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: invalid JSON header: {}", path, e.what()));
  }
  const auto n = static_cast<Eigen::Index>(3 * model.options.num_markers());
  if (static_cast<Eigen::Index>(rows) != n || static_cast<Eigen::Index>(cols) != n) {
    throw Error(fmt::format("{}: H is {} x {}, expected {} x {}", path, rows, cols, n, n));
  }
  model.h.resize(n, n);
  std::memcpy(model.h.data(), data, rows * cols * sizeof(double));
  model.marker_positions = CalcMarkerPositions(model.options);
  return file;
}

}  // namespace

ComplianceModel LoadComplianceModel(const std::string& path) {
  CacheFile file = ReadCacheFile(path);
  if (file.key != CalcComplianceCacheKey(file.model.options)) {
    throw Error(
        fmt::format("{}: key {:016x} does not match its options and this code ({}); it "
                    "was built by other code",
                    path,
                    file.key,
                    FemCodeVersion()));
  }
  return std::move(file.model);
}

ComplianceCacheResult LoadOrBuildComplianceModel(const BodyModelOptions& options,
                                                 const std::string& cache_dir,
                                                 bool show_progress) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const std::uint64_t key = CalcComplianceCacheKey(options);
  ComplianceCacheResult result;
  result.path =
      (std::filesystem::path(cache_dir) / fmt::format("compliance_{:016x}.bin", key)).string();
  if (!std::filesystem::exists(result.path)) {
    result.status = ComplianceCacheStatus::kBuiltMissing;
  } else {
    try {
      CacheFile cached = ReadCacheFile(result.path);
      if (cached.key == key) {
        result.model = std::move(cached.model);
        result.status = ComplianceCacheStatus::kLoaded;
      } else {
        result.status = ComplianceCacheStatus::kRebuiltStale;
        result.reason =
            fmt::format("key {:016x}, expected {:016x} (other options or code)", cached.key, key);
      }
    } catch (const Error& e) {
      result.status = ComplianceCacheStatus::kRebuiltCorrupt;
      result.reason = e.what();
    }
  }
  if (result.status != ComplianceCacheStatus::kLoaded) {
    result.model = CalcComplianceModel(options, show_progress);
    std::error_code error;
    std::filesystem::create_directories(cache_dir, error);
    if (error) throw Error(fmt::format("cannot create the cache directory {}", cache_dir));
    SaveComplianceModel(result.model, result.path);
  }
  result.elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace tac3d::fem
