#include "tac3d/io/recording_export.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>

#include "tac3d/imagefile/image_write.h"
#include "tac3d/io/npy.h"
#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

constexpr const char* kNpyNames[] = {"positions_mm.npy",
                                     "displacements_mm.npy",
                                     "forces_n.npy",
                                     "normals.npy",
                                     "valid.npy",
                                     "contact.npy",
                                     "timestamp_s.npy",
                                     "index.npy",
                                     "flags.npy",
                                     "initialize_progress.npy",
                                     "resultant_force_n.npy",
                                     "resultant_moment_nmm.npy",
                                     "slip_state.npy",
                                     "slip_fraction.npy",
                                     "friction.npy",
                                     "friction_sigma.npy",
                                     "margin.npy",
                                     "margin_sigma.npy",
                                     "least_normal_force_n.npy",
                                     "has_image.npy"};
constexpr const char* kCsvNames[] = {"frames.csv", "markers.csv"};
// Both formats write each recorded camera image as a PNG in this folder.
constexpr const char* kImagesFolder = "images";

// Frame k's image file in the images folder.
std::string ImageFileName(std::int64_t frame_number) { return fmt::format("frame_{:06d}.png", frame_number); }

// Frame k's exported image, relative to the export folder (frames.csv's `image`).
std::string ExportedImageName(std::int64_t frame_number) {
  return fmt::format("{}/{}", kImagesFolder, ImageFileName(frame_number));
}

// Creates the folder if needed and refuses to replace files unless told to, and anything the
// output rule refuses (CheckOutputFile: the recording itself, a device, a symbolic link).
void CheckFolder(const std::string& folder,
                 const std::vector<std::string>& names,
                 bool overwrite,
                 const std::string& recording) {
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::is_directory(folder, ec)) {
    throw Error(fmt::format("export folder '{}' is a file, not a folder", folder));
  }
  fs::create_directories(folder, ec);
  if (ec) throw Error(fmt::format("cannot create export folder '{}': {}", folder, ec.message()));
  for (const std::string& name : names) {
    const fs::path path = fs::path(folder) / name;
    if (!overwrite && fs::exists(fs::symlink_status(path, ec))) {
      throw Error(fmt::format("'{}' already exists (`tac3d recording export --overwrite`, "
                              "RecordingExportOptions::overwrite, replaces it)", path.string()));
    }
    CheckOutputFile(path.string(), "export file", {}, {recording});
  }
  const fs::path images = fs::path(folder) / kImagesFolder;
  const fs::file_status status = fs::symlink_status(images, ec);
  if (fs::exists(status)) {
    if (!fs::is_directory(status)) {
      throw Error(fmt::format("'{}' is not a folder (a file or a symbolic link): the export's images go there",
                              images.string()));
    }
    if (!overwrite) {
      throw Error(fmt::format("'{}' already exists (`tac3d recording export --overwrite`, "
                              "RecordingExportOptions::overwrite, replaces it)", images.string()));
    }
  }
}

// The recorded camera images, written into a temporary folder beside images/ and moved into
// place by Commit() (an earlier export's images/ replaced), so a failed export leaves none.
class ExportImages {
 public:
  explicit ExportImages(const std::string& folder)
      : final_(fs::path(folder) / kImagesFolder),
        temp_(fs::path(folder) / fmt::format("{}.tmp{}", kImagesFolder, ::getpid())) {}
  ~ExportImages() {
    std::error_code ec;
    if (created_ && !committed_) fs::remove_all(temp_, ec);
  }
  void Write(std::int64_t frame_number, const cv::Mat& image) {
    if (!created_) {
      std::error_code ec;
      if (!fs::create_directory(temp_, ec)) {
        throw Error(fmt::format("cannot create the folder '{}'{}", temp_.string(), ec ? ": " + ec.message() : ""));
      }
      created_ = true;
    }
    WriteImageFile((temp_ / ImageFileName(frame_number)).string(), image);
  }
  void Commit() {
    std::error_code ec;
    fs::remove_all(final_, ec);  // checked up front to be a folder, replaced only with overwrite
    if (created_) {
      fs::rename(temp_, final_, ec);
      if (ec) throw Error(fmt::format("cannot rename '{}' to '{}': {}", temp_.string(), final_.string(), ec.message()));
    }
    committed_ = true;
  }

 private:
  fs::path final_, temp_;
  bool created_ = false;
  bool committed_ = false;
};

// The temporary files of an export (CreateTemporaryFile): removed unless Commit() renamed them
// into place.
class TempFiles {
 public:
  TempFiles(const std::string& folder, const std::vector<std::string>& names) {
    for (const std::string& name : names) {
      finals_.push_back((fs::path(folder) / name).string());
      try {
        temps_.push_back(CreateTemporaryFile(finals_.back()));
      } catch (...) {
        Remove();
        throw;
      }
    }
  }
  ~TempFiles() {
    if (!committed_) Remove();
  }
  const std::string& temp(std::size_t i) const { return temps_[i]; }
  const std::vector<std::string>& finals() const { return finals_; }
  void Commit() {
    for (std::size_t i = 0; i < finals_.size(); ++i) ReplaceWithTemporary(temps_[i], finals_[i]);
    committed_ = true;
  }

 private:
  void Remove() {
    std::error_code ec;
    for (const std::string& temp : temps_) fs::remove(temp, ec);
  }

  std::vector<std::string> finals_;
  std::vector<std::string> temps_;
  bool committed_ = false;
};

// Writes one frame at a time to the export's files.
class FrameExporter {
 public:
  virtual ~FrameExporter() = default;
  virtual void Add(std::int64_t frame_number, const RecordedFrame& recorded) = 0;
  virtual void Close() = 0;
};

class NpyExporter : public FrameExporter {
 public:
  NpyExporter(const TempFiles& files, int markers) : bytes_(static_cast<std::size_t>(markers)) {
    const std::int64_t n = markers;
    const std::vector<std::pair<NpyType, std::vector<std::int64_t>>> layout = {
        {NpyType::kFloat64, {n, 3}},
        {NpyType::kFloat64, {n, 3}},
        {NpyType::kFloat64, {n, 3}},
        {NpyType::kFloat64, {n, 3}},
        {NpyType::kBool, {n}},
        {NpyType::kBool, {n}},
        {NpyType::kFloat64, {}},
        {NpyType::kInt64, {}},
        {NpyType::kUint32, {}},
        {NpyType::kInt64, {}},
        {NpyType::kFloat64, {3}},
        {NpyType::kFloat64, {3}},
        {NpyType::kUint32, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kFloat64, {}},
        {NpyType::kBool, {}}};
    for (std::size_t i = 0; i < layout.size(); ++i) {
      writers_.push_back(
          std::make_unique<NpyWriter>(files.temp(i), layout[i].first, layout[i].second));
    }
  }

  void Add(std::int64_t, const RecordedFrame& recorded) override {
    const TactileFrame& f = recorded.frame;
    writers_[0]->Append(f.positions_mm.data());
    writers_[1]->Append(f.displacements_mm.data());
    writers_[2]->Append(f.forces_n.data());
    writers_[3]->Append(f.normals.data());
    AppendBools(*writers_[4], f.valid);
    AppendBools(*writers_[5], f.contact);
    writers_[6]->Append(&f.timestamp_s);
    writers_[7]->Append(&f.index);
    writers_[8]->Append(&f.flags);
    const std::int64_t progress = f.initialize_progress;
    writers_[9]->Append(&progress);
    writers_[10]->Append(f.resultant_force_n.data());
    writers_[11]->Append(f.resultant_moment_nmm.data());
    const std::uint32_t state = static_cast<std::uint32_t>(f.slip.state);
    writers_[12]->Append(&state);
    writers_[13]->Append(&f.slip.fraction);
    writers_[14]->Append(&f.slip.friction);
    writers_[15]->Append(&f.slip.friction_sigma);
    writers_[16]->Append(&f.slip.margin);
    writers_[17]->Append(&f.slip.margin_sigma);
    writers_[18]->Append(&f.slip.least_normal_force_n);
    const std::uint8_t has_image = recorded.image.empty() ? 0 : 1;
    writers_[19]->Append(&has_image);
  }

  void Close() override {
    for (auto& w : writers_) w->Close();
  }

 private:
  void AppendBools(NpyWriter& writer, const std::vector<bool>& values) {
    for (std::size_t i = 0; i < values.size(); ++i) bytes_[i] = values[i] ? 1 : 0;
    writer.Append(bytes_.data());
  }

  std::vector<std::unique_ptr<NpyWriter>> writers_;
  std::vector<std::uint8_t> bytes_;
};

// A CSV field: quoted when it holds a comma, a quote or a line break.
std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (const char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

class CsvExporter : public FrameExporter {
 public:
  static constexpr const char* kFramesHeader =
      "frame,index,timestamp_s,sn,rows,cols,initialize_progress,flags,flag_names,valid_markers,"
      "contact_markers,image_rows,image_cols,fx_n,fy_n,fz_n,mx_nmm,my_nmm,mz_nmm,slip_state,"
      "slip_fraction,friction,friction_sigma,margin,margin_sigma,least_normal_force_n,image\n";
  static constexpr const char* kMarkersHeader =
      "frame,index,timestamp_s,marker,row,col,valid,contact,x_mm,y_mm,z_mm,dx_mm,dy_mm,dz_mm,"
      "fx_n,fy_n,fz_n,nx,ny,nz\n";

  explicit CsvExporter(const TempFiles& files)
      : frames_path_(files.temp(0)), markers_path_(files.temp(1)) {
    Open(&frames_, frames_path_);
    Open(&markers_, markers_path_);
    frames_ << kFramesHeader;
    markers_ << kMarkersHeader;
  }

  void Add(std::int64_t frame_number, const RecordedFrame& recorded) override {
    const TactileFrame& f = recorded.frame;
    int valid = 0, contact = 0;
    for (int i = 0; i < f.num_markers(); ++i) {
      valid += f.valid[i];
      contact += f.contact[i];
    }
    // {} prints the shortest text that reads back as the same double.
    buffer_.clear();
    fmt::format_to(std::back_inserter(buffer_),
                   "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                   frame_number,
                   f.index,
                   f.timestamp_s,
                   CsvField(f.sn),
                   f.rows,
                   f.cols,
                   f.initialize_progress,
                   f.flags,
                   FrameFlagNames(f.flags),
                   valid,
                   contact,
                   recorded.image.rows,
                   recorded.image.cols,
                   f.resultant_force_n.x(),
                   f.resultant_force_n.y(),
                   f.resultant_force_n.z(),
                   f.resultant_moment_nmm.x(),
                   f.resultant_moment_nmm.y(),
                   f.resultant_moment_nmm.z(),
                   SlipStateName(f.slip.state),
                   f.slip.fraction,
                   f.slip.friction,
                   f.slip.friction_sigma,
                   f.slip.margin,
                   f.slip.margin_sigma,
                   f.slip.least_normal_force_n,
                   recorded.image.empty() ? std::string() : ExportedImageName(frame_number));
    frames_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
    for (int i = 0; i < f.num_markers(); ++i) {
      const Eigen::Vector3d& p = f.positions_mm[i];
      const Eigen::Vector3d& d = f.displacements_mm[i];
      const Eigen::Vector3d& g = f.forces_n[i];
      const Eigen::Vector3d& n = f.normals[i];
      fmt::format_to(std::back_inserter(buffer_),
                     "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                     frame_number,
                     f.index,
                     f.timestamp_s,
                     i,
                     i / f.cols,
                     i % f.cols,
                     f.valid[i] ? 1 : 0,
                     f.contact[i] ? 1 : 0,
                     p.x(),
                     p.y(),
                     p.z(),
                     d.x(),
                     d.y(),
                     d.z(),
                     g.x(),
                     g.y(),
                     g.z(),
                     n.x(),
                     n.y(),
                     n.z());
    }
    markers_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
  }

  void Close() override {
    Finish(&frames_, frames_path_);
    Finish(&markers_, markers_path_);
  }

 private:
  static void Open(std::ofstream* out, const std::string& path) {
    out->open(path, std::ios::binary | std::ios::trunc);
    if (!*out) throw Error(fmt::format("cannot create '{}': {}", path, std::strerror(errno)));
  }
  static void Finish(std::ofstream* out, const std::string& path) {
    out->close();
    if (!*out) throw Error(fmt::format("cannot write '{}'", path));
  }

  std::string frames_path_, markers_path_;
  std::ofstream frames_, markers_;
  std::string buffer_;
};

}  // namespace

RecordingExportFormat ParseRecordingExportFormat(const std::string& name) {
  if (name == "csv") return RecordingExportFormat::kCsv;
  if (name == "npy") return RecordingExportFormat::kNpy;
  throw Error(fmt::format("export format '{}': expected csv or npy", name));
}

std::vector<std::string> RecordingExportFileNames(RecordingExportFormat format) {
  if (format == RecordingExportFormat::kCsv) return {std::begin(kCsvNames), std::end(kCsvNames)};
  return {std::begin(kNpyNames), std::end(kNpyNames)};
}

RecordingExportResult ExportRecording(const std::string& recording,
                                      const std::string& folder,
                                      const RecordingExportOptions& options) {
  RecordingReader reader(recording);
  const std::vector<std::string> names = RecordingExportFileNames(options.format);
  CheckFolder(folder, names, options.overwrite, recording);

  std::optional<RecordedFrame> recorded = reader.Next();
  if (!recorded) {
    throw Error(fmt::format("nothing to export: {}", reader.message()));
  }
  RecordingExportResult result;
  result.rows = recorded->frame.rows;
  result.cols = recorded->frame.cols;
  TempFiles files(folder, names);
  ExportImages images(folder);
  std::unique_ptr<FrameExporter> exporter;
  if (options.format == RecordingExportFormat::kNpy) {
    exporter = std::make_unique<NpyExporter>(files, result.rows * result.cols);
  } else {
    exporter = std::make_unique<CsvExporter>(files);
  }
  for (; recorded; recorded = reader.Next()) {
    const TactileFrame& f = recorded->frame;
    if (options.format == RecordingExportFormat::kNpy &&
        (f.rows != result.rows || f.cols != result.cols)) {
      throw Error(fmt::format(
          "recording '{}': frame {} (index {}) has a {} x {} marker grid, the first a {} x {}; "
          ".npy arrays need one grid (export as csv instead)",
          recording,
          result.frames,
          f.index,
          f.rows,
          f.cols,
          result.rows,
          result.cols));
    }
    exporter->Add(result.frames, *recorded);
    if (!recorded->image.empty()) {
      images.Write(result.frames, recorded->image);
      ++result.images;
    }
    ++result.frames;
  }
  exporter->Close();
  files.Commit();
  images.Commit();
  result.files = files.finals();
  result.status = reader.status();
  result.message = reader.message();
  return result;
}

}  // namespace tac3d
