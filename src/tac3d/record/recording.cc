#include "tac3d/record/recording.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cstring>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"
#include "tac3d/util/seconds_since.h"
#include "tac3d/util/stoppable_sleep.h"

namespace tac3d {
namespace {

// Values are copied to and from the file with memcpy: the file is little-endian.
static_assert(std::endian::native == std::endian::little, "tac3d assumes a little-endian host");

constexpr std::size_t kFileHeaderBytes = sizeof(kRecordingMagic) + sizeof(std::uint32_t);
constexpr std::size_t kRecordHeaderBytes = 2 * sizeof(std::uint32_t);

constexpr std::array<std::uint32_t, 256> MakeCrcTable() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}
constexpr auto kCrcTable = MakeCrcTable();

template <typename T>
void Put(std::vector<std::uint8_t>* out, const T& value) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
  out->insert(out->end(), p, p + sizeof(T));
}

void PutBytes(std::vector<std::uint8_t>* out, const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  out->insert(out->end(), p, p + size);
}

void PutVectors(std::vector<std::uint8_t>* out, const std::vector<Eigen::Vector3d>& v) {
  PutBytes(out, v.data(), v.size() * sizeof(Eigen::Vector3d));
}

void PutFlags(std::vector<std::uint8_t>* out, const std::vector<bool>& v) {
  for (const bool b : v) out->push_back(b ? 1 : 0);
}

// Reads a payload front to back; any read past its end or inconsistent value throws Error,
// which the reader reports as corruption.
class PayloadReader {
 public:
  PayloadReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename T>
  T Get(const char* what) {
    T value;
    GetBytes(&value, sizeof(T), what);
    return value;
  }
  void GetBytes(void* out, std::size_t size, const char* what) {
    if (size > size_ - at_) {
      throw Error(fmt::format("{} runs past the end of the record", what));
    }
    std::memcpy(out, data_ + at_, size);
    at_ += size;
  }
  void GetVectors(std::vector<Eigen::Vector3d>* v, std::size_t n, const char* what) {
    v->resize(n);
    GetBytes(v->data(), n * sizeof(Eigen::Vector3d), what);
  }
  void GetFlags(std::vector<bool>* v, std::size_t n, const char* what) {
    if (n > size_ - at_) throw Error(fmt::format("{} runs past the end of the record", what));
    v->resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t b = data_[at_ + i];
      if (b > 1) throw Error(fmt::format("{}[{}] is {}, not 0 or 1", what, i, b));
      (*v)[i] = b == 1;
    }
    at_ += n;
  }
  std::size_t remaining() const { return size_ - at_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

void WriteAll(int fd, const std::uint8_t* data, std::size_t size, const std::string& path) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(fmt::format("cannot write recording '{}': {}", path, std::strerror(errno)));
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
}

}  // namespace

std::uint32_t Crc32(std::uint32_t crc, const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = kCrcTable[(crc ^ p[i]) & 0xff] ^ (crc >> 8);
  return ~crc;
}

RecordingWriter::RecordingWriter(const std::string& path, const RecordingWriterOptions& options)
    : path_(path), sync_every_frame_(options.sync_every_frame) {
  CheckOutputFile(path, "recording");  // a folder, a device, a link, a missing folder
  // O_NOFOLLOW: a link planted after the check is refused, not written through.
  const int flags =
      O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | (options.overwrite ? O_TRUNC : O_EXCL);
  fd_ = ::open(path.c_str(), flags, 0644);
  if (fd_ < 0) {
    throw Error(fmt::format("cannot create recording '{}': {}{}",
                            path,
                            std::strerror(errno),
                            errno == EEXIST ? " (it exists: RecordingWriterOptions::overwrite, `tac3d run --overwrite`, replaces it)" : ""));
  }
  std::vector<std::uint8_t> header;
  PutBytes(&header, kRecordingMagic, sizeof(kRecordingMagic));
  Put(&header, kRecordingVersion);
  WriteAll(fd_, header.data(), header.size(), path_);
}

RecordingWriter::~RecordingWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void RecordingWriter::Write(const TactileFrame& frame, const cv::Mat& image) {
  frame.Validate();
  if (frame.sn.size() > 0xffff) {
    throw Error(
        fmt::format("recording '{}': SN of {} bytes, at most 65535", path_, frame.sn.size()));
  }
  if (!image.empty() && image.type() != CV_8UC1) {
    throw Error(fmt::format("recording '{}': the image must be 8-bit mono (CV_8UC1), not type {}",
                            path_,
                            image.type()));
  }
  record_.assign(kRecordHeaderBytes, 0);  // length and CRC, filled in below
  Put(&record_, static_cast<std::uint32_t>(frame.rows));
  Put(&record_, static_cast<std::uint32_t>(frame.cols));
  Put(&record_, frame.index);
  Put(&record_, frame.timestamp_s);
  Put(&record_, static_cast<std::int32_t>(frame.initialize_progress));
  Put(&record_, frame.flags);
  Put(&record_, static_cast<std::uint16_t>(frame.sn.size()));
  PutBytes(&record_, frame.sn.data(), frame.sn.size());
  PutBytes(&record_, frame.resultant_force_n.data(), 3 * sizeof(double));
  PutBytes(&record_, frame.resultant_moment_nmm.data(), 3 * sizeof(double));
  PutVectors(&record_, frame.positions_mm);
  PutVectors(&record_, frame.displacements_mm);
  PutVectors(&record_, frame.forces_n);
  PutVectors(&record_, frame.normals);
  PutFlags(&record_, frame.valid);
  PutFlags(&record_, frame.contact);
  Put(&record_, static_cast<std::uint8_t>(frame.slip.state));
  Put(&record_, frame.slip.fraction);
  Put(&record_, frame.slip.friction);
  Put(&record_, frame.slip.friction_sigma);
  Put(&record_, frame.slip.margin);
  Put(&record_, frame.slip.margin_sigma);
  Put(&record_, frame.slip.least_normal_force_n);
  Put(&record_, static_cast<std::uint32_t>(image.rows));
  Put(&record_, static_cast<std::uint32_t>(image.cols));
  for (int r = 0; r < image.rows; ++r) PutBytes(&record_, image.ptr(r), image.cols);

  const std::size_t payload_size = record_.size() - kRecordHeaderBytes;
  if (payload_size > kMaxRecordBytes) {
    throw Error(fmt::format(
        "recording '{}': a record of {} bytes exceeds {}", path_, payload_size, kMaxRecordBytes));
  }
  const auto length = static_cast<std::uint32_t>(payload_size);
  const std::uint32_t crc =
      Crc32(Crc32(0, &length, sizeof(length)), record_.data() + kRecordHeaderBytes, payload_size);
  std::memcpy(record_.data(), &length, sizeof(length));
  std::memcpy(record_.data() + sizeof(length), &crc, sizeof(crc));
  WriteAll(fd_, record_.data(), record_.size(), path_);
  if (sync_every_frame_ && ::fdatasync(fd_) != 0) {
    throw Error(fmt::format("cannot sync recording '{}': {}", path_, std::strerror(errno)));
  }
  ++frames_written_;
}

const char* RecordingStatusName(RecordingStatus status) {
  switch (status) {
    case RecordingStatus::kReading:
      return "reading";
    case RecordingStatus::kComplete:
      return "complete";
    case RecordingStatus::kTruncated:
      return "truncated";
    case RecordingStatus::kCorrupt:
      return "corrupt";
  }
  TAC3D_DEMAND(false);
}

RecordingReader::RecordingReader(const std::string& path) : path_(path) {
  RequireRegularFile(path, "recording");  // a FIFO would block the open, a device never end
  in_.open(path, std::ios::binary);
  if (!in_) throw Error(fmt::format("cannot open recording '{}'", path));
  char header[kFileHeaderBytes];
  in_.read(header, sizeof(header));
  if (in_.gcount() != static_cast<std::streamsize>(sizeof(header)) ||
      std::memcmp(header, kRecordingMagic, sizeof(kRecordingMagic)) != 0) {
    throw Error(fmt::format("'{}' is not a tac3d recording (no 'TAC3DREC' header)", path));
  }
  std::uint32_t version;
  std::memcpy(&version, header + sizeof(kRecordingMagic), sizeof(version));
  if (version < kOldestRecordingVersion || version > kRecordingVersion) {
    throw Error(fmt::format("recording '{}' has format version {}; this reader knows {} to {}",
                            path,
                            version,
                            kOldestRecordingVersion,
                            kRecordingVersion));
  }
  version_ = version;
  offset_ = kFileHeaderBytes;
}

std::nullopt_t RecordingReader::End(RecordingStatus status, const std::string& message) {
  status_ = status;
  message_ = fmt::format("recording '{}': {} after {} frames at byte {}: {}",
                         path_,
                         RecordingStatusName(status),
                         frames_read_,
                         offset_,
                         message);
  return std::nullopt;
}

std::optional<RecordedFrame> RecordingReader::Next() {
  if (status_ != RecordingStatus::kReading) return std::nullopt;
  std::uint32_t head[2];
  in_.read(reinterpret_cast<char*>(head), sizeof(head));
  if (in_.gcount() == 0) return End(RecordingStatus::kComplete, "end of file");
  if (in_.gcount() != static_cast<std::streamsize>(sizeof(head))) {
    return End(RecordingStatus::kTruncated,
               fmt::format("{} of the {} bytes of a record header", in_.gcount(), sizeof(head)));
  }
  const std::uint32_t length = head[0];
  if (length > kMaxRecordBytes) {
    return End(RecordingStatus::kCorrupt,
               fmt::format("record length {} exceeds {}", length, kMaxRecordBytes));
  }
  record_.resize(length);
  in_.read(reinterpret_cast<char*>(record_.data()), length);
  if (in_.gcount() != static_cast<std::streamsize>(length)) {
    return End(RecordingStatus::kTruncated,
               fmt::format("{} of the record's {} bytes", in_.gcount(), length));
  }
  const std::uint32_t crc = Crc32(Crc32(0, &length, sizeof(length)), record_.data(), length);
  if (crc != head[1]) {
    return End(RecordingStatus::kCorrupt,
               fmt::format("checksum 0x{:08x}, the record's bytes give 0x{:08x}", head[1], crc));
  }

  RecordedFrame recorded;
  TactileFrame& frame = recorded.frame;
  try {
    PayloadReader payload(record_.data(), record_.size());
    const auto rows = payload.Get<std::uint32_t>("rows");
    const auto cols = payload.Get<std::uint32_t>("cols");
    // Each marker takes more than 4 * 24 bytes, so the payload bounds the grid (no overflow).
    if (rows < 1 || cols < 1 || std::uint64_t{rows} * cols > length / 96) {
      throw Error(fmt::format("a {} x {} grid does not fit in the record", rows, cols));
    }
    frame.rows = static_cast<int>(rows);
    frame.cols = static_cast<int>(cols);
    const std::size_t n = std::size_t{rows} * cols;
    frame.index = payload.Get<std::int64_t>("index");
    frame.timestamp_s = payload.Get<double>("timestamp");
    frame.initialize_progress = payload.Get<std::int32_t>("initialize_progress");
    frame.flags = payload.Get<std::uint32_t>("flags");
    frame.sn.resize(payload.Get<std::uint16_t>("SN length"));
    payload.GetBytes(frame.sn.data(), frame.sn.size(), "SN");
    payload.GetBytes(frame.resultant_force_n.data(), 3 * sizeof(double), "resultant force");
    payload.GetBytes(frame.resultant_moment_nmm.data(), 3 * sizeof(double), "resultant moment");
    payload.GetVectors(&frame.positions_mm, n, "positions");
    payload.GetVectors(&frame.displacements_mm, n, "displacements");
    payload.GetVectors(&frame.forces_n, n, "forces");
    payload.GetVectors(&frame.normals, n, "normals");
    payload.GetFlags(&frame.valid, n, "valid");
    payload.GetFlags(&frame.contact, n, "contact");
    if (version_ >= 2) {
      // Range-checked by frame.Validate() below.
      frame.slip.state = static_cast<SlipState>(payload.Get<std::uint8_t>("slip state"));
      frame.slip.fraction = payload.Get<double>("slip fraction");
      frame.slip.friction = payload.Get<double>("friction");
      frame.slip.friction_sigma = payload.Get<double>("friction sigma");
    }
    if (version_ >= 3) {
      frame.slip.margin = payload.Get<double>("slip margin");
      frame.slip.margin_sigma = payload.Get<double>("slip margin sigma");
      frame.slip.least_normal_force_n = payload.Get<double>("least normal force");
    }
    const auto image_rows = payload.Get<std::uint32_t>("image rows");
    const auto image_cols = payload.Get<std::uint32_t>("image cols");
    if (std::uint64_t{image_rows} * image_cols != payload.remaining() ||
        (image_rows == 0) != (image_cols == 0)) {
      throw Error(fmt::format("a {} x {} image does not match the {} bytes left in the record",
                              image_rows,
                              image_cols,
                              payload.remaining()));
    }
    if (image_rows > 0) {
      recorded.image.create(static_cast<int>(image_rows), static_cast<int>(image_cols), CV_8UC1);
      payload.GetBytes(recorded.image.data, payload.remaining(), "image");
    }
    frame.Validate();
  } catch (const Error& e) {
    return End(RecordingStatus::kCorrupt, fmt::format("frame {}: {}", frames_read_, e.what()));
  }
  offset_ += kRecordHeaderBytes + length;
  ++frames_read_;
  return recorded;
}

double ReplayDelay(double first_timestamp_s, double timestamp_s, double elapsed_s, double speed) {
  if (!(speed > 0.0)) return 0.0;
  return std::max(0.0, (timestamp_s - first_timestamp_s) / speed - elapsed_s);
}

bool ReplayPacer::Wait(double timestamp_s, const std::atomic<bool>* stop) {
  if (stop != nullptr && *stop) return false;
  const auto now = std::chrono::steady_clock::now();
  if (!first_timestamp_s_) {
    first_timestamp_s_ = timestamp_s;
    start_ = now;
    return true;
  }
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  const double delay_s = ReplayDelay(*first_timestamp_s_, timestamp_s, elapsed_s, speed_);
  if (delay_s <= 0.0) return true;
  const bool shortened = delay_s > max_wait_s_;
  const bool due = SleepUnlessStopped(shortened ? max_wait_s_ : delay_s, stop);
  waited_s_ += SecondsSince(now);
  if (shortened) {
    // The pace goes on from this frame, shown now.
    shortened_wait_s_ = delay_s;
    first_timestamp_s_ = timestamp_s;
    start_ = std::chrono::steady_clock::now();
  }
  return due;
}

}  // namespace tac3d
