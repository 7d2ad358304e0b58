#include "tac3d/vendor_formats/vendor_recording.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

struct FieldSlot {
  const char* name;
  NpyArray VendorRecording::*array;
  NpyType type;
  int rank;  ///< 3: frames x width x 3, 1: frames
  bool one_row;  ///< frames x 1 x 3
};

constexpr std::array<FieldSlot, 7> kSlots = {{
    {"3D_Positions", &VendorRecording::positions, NpyType::kFloat64, 3, false},
    {"3D_Displacements", &VendorRecording::displacements, NpyType::kFloat64, 3, false},
    {"3D_Forces", &VendorRecording::forces, NpyType::kFloat64, 3, false},
    {"3D_ResultantForce", &VendorRecording::resultant_force, NpyType::kFloat64, 3, true},
    {"3D_ResultantMoment", &VendorRecording::resultant_moment, NpyType::kFloat64, 3, true},
    {"index", &VendorRecording::index, NpyType::kInt64, 1, false},
    {"sendTimestamp", &VendorRecording::send_timestamp, NpyType::kFloat64, 1, false},
}};

std::string ShapeText(const std::vector<std::int64_t>& shape) {
  return fmt::format("({})", fmt::join(shape, ", "));
}

// Every field against the others: one frame count, one marker count, the documented shapes.
void CheckShapes(const VendorRecording& recording, const std::string& folder) {
  const std::int64_t frames = recording.frames();
  const std::int64_t markers = recording.markers();
  for (const FieldSlot& slot : kSlots) {
    const NpyArray& a = recording.*slot.array;
    const std::string where = (fs::path(folder) / (std::string(slot.name) + ".npy")).string();
    std::vector<std::int64_t> expected = {frames};
    if (slot.rank == 3) expected = {frames, slot.one_row ? 1 : markers, 3};
    if (a.type != slot.type) {
      throw Error(fmt::format("'{}': dtype '{}', a vendor recording's {} is '{}'", where, NpyDescr(a.type),
                              slot.name, NpyDescr(slot.type)));
    }
    if (a.shape != expected) {
      throw Error(fmt::format("'{}': shape {}, expected {} (frames from index.npy, markers from "
                              "3D_Positions.npy)",
                              where, ShapeText(a.shape), ShapeText(expected)));
    }
  }
  if (markers < 1) throw Error(fmt::format("'{}': a recording without markers", folder));
}

}  // namespace

std::vector<std::string> FindVendorRecordingFolders(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw Error(fmt::format("'{}' is not a folder", folder));
  if (fs::exists(fs::path(folder) / "index.npy", error)) return {folder};
  std::vector<std::string> found;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_directory() && fs::exists(entry.path() / "index.npy")) found.push_back(entry.path().string());
  }
  std::sort(found.begin(), found.end());
  if (found.empty()) {
    throw Error(fmt::format("'{}' holds no vendor recording: expected the <SN> folder of index.npy, "
                            "3D_Positions.npy, ... or a recording folder holding such folders",
                            folder));
  }
  return found;
}

namespace {

std::string CsvDouble(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  std::string s(buffer, result.ptr);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // Python writes 0.0, not 0
  return s;
}

}  // namespace

Eigen::MatrixX3d VendorRecording::Frame(const NpyArray& field, std::int64_t frame) {
  TAC3D_DEMAND(field.type == NpyType::kFloat64 && field.shape.size() == 3 && field.shape[2] == 3);
  TAC3D_DEMAND(frame >= 0 && frame < field.shape[0]);
  const std::int64_t frames = field.shape[0], rows = field.shape[1];
  Eigen::MatrixX3d values(rows, 3);
  for (std::int64_t i = 0; i < rows; ++i) {
    for (std::int64_t k = 0; k < 3; ++k) {
      // Element (frame, i, k): C order has the last index fastest, Fortran order the first.
      const std::int64_t at = field.fortran_order ? frame + frames * (i + rows * k) : (frame * rows + i) * 3 + k;
      std::memcpy(&values(i, k), field.data.data() + at * sizeof(double), sizeof(double));
    }
  }
  return values;
}

Eigen::MatrixX3d VendorRecording::ReferencePositions(std::int64_t frame) const {
  return Frame(positions, frame) - Frame(displacements, frame);
}

std::int64_t VendorRecording::FirstNonFiniteMarker(std::int64_t frame) const {
  const Eigen::MatrixX3d p = Frame(positions, frame), d = Frame(displacements, frame),
                         f = Frame(forces, frame);
  for (std::int64_t i = 0; i < p.rows(); ++i) {
    if (!MarkerIsFinite(p, d, f, i)) return i;
  }
  return -1;
}

std::int64_t VendorRecording::FramesWithNonFiniteResultant() const {
  std::int64_t count = 0;
  for (std::int64_t f = 0; f < frames(); ++f) {
    if (!Frame(resultant_force, f).allFinite() || !Frame(resultant_moment, f).allFinite()) ++count;
  }
  return count;
}

double VendorRecording::MaxReferenceShiftMm() const {
  if (frames() == 0) return 0.0;
  const Eigen::MatrixX3d first = ReferencePositions(0);
  double shift = 0.0;
  for (std::int64_t f = 1; f < frames(); ++f) {
    shift = std::max(shift, (ReferencePositions(f) - first).rowwise().norm().maxCoeff());
  }
  return shift;
}

VendorRecording ReadVendorSensorFolder(const std::string& serial_folder) {
  VendorRecording recording;
  recording.serial_number = fs::path(serial_folder).filename().string();
  for (const FieldSlot& slot : kSlots) {
    const fs::path path = fs::path(serial_folder) / (std::string(slot.name) + ".npy");
    std::error_code error;
    if (!fs::exists(path, error)) {
      throw Error(fmt::format("'{}' is missing: a vendor recording holds {}.npy", path.string(), slot.name));
    }
    recording.*slot.array = ReadNpy(path.string());
  }
  CheckShapes(recording, serial_folder);
  // A replay is paced by these: a NaN or infinite one has no place on a clock.
  const std::vector<double> time = recording.send_timestamp.Float64Values();
  for (size_t f = 0; f < time.size(); ++f) {
    if (!std::isfinite(time[f])) {
      throw Error(fmt::format("'{}': frame {}'s time is {}: a vendor recording's sendTimestamp are finite seconds",
                              (fs::path(serial_folder) / "sendTimestamp.npy").string(), f, time[f]));
    }
  }
  return recording;
}

VendorRecording ReadVendorRecording(const std::string& folder) {
  const std::vector<std::string> found = FindVendorRecordingFolders(folder);
  if (found.size() != 1) {
    std::vector<std::string> names;
    for (const std::string& f : found) names.push_back(fs::path(f).filename().string());
    throw Error(fmt::format("'{}' holds the recordings of {} sensors ({}): give one <SN> folder", folder,
                            found.size(), fmt::join(names, ", ")));
  }
  return ReadVendorSensorFolder(found[0]);
}

std::vector<VendorRecording> ReadVendorRecordings(const std::string& folder) {
  std::vector<VendorRecording> recordings;
  for (const std::string& serial_folder : FindVendorRecordingFolders(folder)) {
    recordings.push_back(ReadVendorSensorFolder(serial_folder));
  }
  return recordings;
}

void WriteVendorRecording(const VendorRecording& recording, const std::string& folder) {
  if (recording.serial_number.empty() || recording.serial_number.find_first_of("/\\") != std::string::npos ||
      recording.serial_number == "." || recording.serial_number == "..") {
    throw Error(fmt::format("'{}' is not a serial number to name a folder with", recording.serial_number));
  }
  const fs::path serial_folder = fs::path(folder) / recording.serial_number;
  CheckShapes(recording, serial_folder.string());
  MakeDirectory(serial_folder.string());
  for (const FieldSlot& slot : kSlots) {
    WriteNpy((serial_folder / (std::string(slot.name) + ".npy")).string(), recording.*slot.array);
  }
  const std::vector<std::int64_t> index = recording.index.Int64Values();
  const std::vector<double> time = recording.send_timestamp.Float64Values();
  const std::vector<double> force = recording.resultant_force.Float64Values();
  const std::vector<double> moment = recording.resultant_moment.Float64Values();
  // CRLF line ends, as the vendor's recorder (on Windows) writes them.
  std::string csv = "index,timestamp,FRx,FRy,FRz,MRx,MRy,MRz\r\n";
  for (size_t f = 0; f < index.size(); ++f) {
    csv += fmt::format("{},{}", index[f], CsvDouble(time[f]));
    for (const double value : {force[3 * f], force[3 * f + 1], force[3 * f + 2], moment[3 * f], moment[3 * f + 1],
                               moment[3 * f + 2]}) {
      csv += ',';
      csv += CsvDouble(value);
    }
    csv += "\r\n";
  }
  WriteTextFileAtomically((serial_folder / "overview.csv").string(), csv);
}

}  // namespace tac3d
