#include "tac3d/record/recording_info.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

namespace tac3d {
namespace {

template <typename T>
void AddDistinct(std::vector<T>* values, const T& value) {
  if (std::find(values->begin(), values->end(), value) == values->end()) values->push_back(value);
}

std::string Grids(const std::vector<RecordingInfo::Grid>& grids) {
  std::string s;
  for (const auto& g : grids) s += fmt::format("{}{} x {}", s.empty() ? "" : ", ", g.rows, g.cols);
  return s.empty() ? "none" : s;
}

std::string Join(const std::vector<std::string>& values) {
  std::string s;
  for (const auto& v : values) s += fmt::format("{}{}", s.empty() ? "" : ", ", v);
  return s.empty() ? "none" : s;
}

}  // namespace

double RecordingInfo::mean_fps() const {
  const double d = duration_s();
  return frames > 1 && d > 0.0 ? static_cast<double>(frames - 1) / d : 0.0;
}

std::string RecordingInfo::BriefReport() const {
  return fmt::format("{}: {} frames, {:.3f} s, SN {}, {}, {}",
                     path,
                     frames,
                     duration_s(),
                     Join(sns),
                     Grids(grids),
                     RecordingStatusName(status));
}

std::string RecordingInfo::FullReport() const {
  std::string s;
  const auto row = [&s](const std::string& name, const std::string& value) {
    s += fmt::format("{:<32} {}\n", name, value);
  };
  row("file", fmt::format("{} ({} bytes)", path, file_bytes));
  row("frames", fmt::format("{}", frames));
  row("index",
      frames > 0 ? fmt::format("{} .. {} ({} gaps)", first_index, last_index, index_gaps) : "none");
  row("timestamps",
      frames > 0 ? fmt::format("{:.6f} .. {:.6f} s{}",
                               first_timestamp_s,
                               last_timestamp_s,
                               timestamps_backwards > 0
                                   ? fmt::format(" ({} going backwards)", timestamps_backwards)
                                   : "")
                 : "none");
  row("duration", fmt::format("{:.3f} s ({:.2f} frames/s)", duration_s(), mean_fps()));
  row("SN", Join(sns));
  row("markers (rows x cols)", Grids(grids));
  row("images",
      frames_with_image > 0
          ? fmt::format("{} of {} frames, {}", frames_with_image, frames, Grids(image_sizes))
          : "none");
  for (std::size_t i = 0; i < std::size(kAllFrameFlags); ++i) {
    row(fmt::format("flag {}", FrameFlagName(kAllFrameFlags[i])),
        fmt::format("{} frames", flag_frames[i]));
  }
  row("no flag", fmt::format("{} frames", unflagged_frames));
  row("status", RecordingStatusName(status));
  if (tail_bytes() > 0) {
    row("unread tail", fmt::format("{} bytes after byte {}", tail_bytes(), good_bytes));
  }
  row("reader", message);
  return s;
}

RecordingInfo ReadRecordingInfo(const std::string& path) {
  RecordingReader reader(path);
  RecordingInfo info;
  info.path = path;
  std::error_code ec;
  info.file_bytes = static_cast<std::int64_t>(std::filesystem::file_size(path, ec));
  while (const std::optional<RecordedFrame> recorded = reader.Next()) {
    const TactileFrame& f = recorded->frame;
    if (info.frames == 0) {
      info.first_index = f.index;
      info.first_timestamp_s = f.timestamp_s;
    } else {
      info.index_gaps += f.index != info.last_index + 1;
      info.timestamps_backwards += f.timestamp_s < info.last_timestamp_s;
    }
    info.last_index = f.index;
    info.last_timestamp_s = f.timestamp_s;
    ++info.frames;
    AddDistinct(&info.sns, f.sn);
    AddDistinct(&info.grids, RecordingInfo::Grid{f.rows, f.cols});
    if (!recorded->image.empty()) {
      ++info.frames_with_image;
      AddDistinct(&info.image_sizes,
                  RecordingInfo::Grid{recorded->image.rows, recorded->image.cols});
    }
    for (std::size_t i = 0; i < std::size(kAllFrameFlags); ++i) {
      info.flag_frames[i] += f.has(kAllFrameFlags[i]);
    }
    info.unflagged_frames += f.flags == 0;
  }
  info.good_bytes = reader.offset();
  info.status = reader.status();
  info.message = reader.message();
  return info;
}

}  // namespace tac3d
