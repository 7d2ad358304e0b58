#include "tac3d/io/npy.h"

#include <fmt/format.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <limits>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the .npy files are written little-endian");

constexpr char kMagic[] = "\x93NUMPY";             // 6 bytes and the terminating zero
constexpr std::size_t kPreambleBytes = 6 + 2 + 2;  // magic, version 1.0, u16 header length
constexpr std::size_t kAlign = 64;

std::string ShapeTuple(const std::vector<std::int64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (shape[i] < 0) throw Error(fmt::format(".npy shape: dimension {} is {} < 0", i, shape[i]));
    s += fmt::format("{}{}", i > 0 ? ", " : "", shape[i]);
  }
  return s + (shape.size() == 1 ? ",)" : ")");
}

}  // namespace

const char* NpyDescr(NpyType type) {
  switch (type) {
    case NpyType::kFloat64:
      return "<f8";
    case NpyType::kInt64:
      return "<i8";
    case NpyType::kUint32:
      return "<u4";
    case NpyType::kBool:
      return "|b1";
  }
  TAC3D_DEMAND(false);
}

std::size_t NpyItemBytes(NpyType type) {
  switch (type) {
    case NpyType::kFloat64:
    case NpyType::kInt64:
      return 8;
    case NpyType::kUint32:
      return 4;
    case NpyType::kBool:
      return 1;
  }
  TAC3D_DEMAND(false);
}

std::string NpyHeader(NpyType type,
                      const std::vector<std::int64_t>& shape,
                      std::size_t total_bytes) {
  const std::string dict = fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}",
                                       NpyDescr(type),
                                       ShapeTuple(shape));
  const std::size_t needed = kPreambleBytes + dict.size() + 1;  // + '\n'
  if (total_bytes == 0) total_bytes = (needed + kAlign - 1) / kAlign * kAlign;
  if (total_bytes % kAlign != 0 || total_bytes < needed || total_bytes - kPreambleBytes > 0xffff) {
    throw Error(fmt::format(".npy header of {} bytes cannot hold {} bytes in a multiple of {}",
                            total_bytes,
                            needed,
                            kAlign));
  }
  const auto header_len = static_cast<std::uint16_t>(total_bytes - kPreambleBytes);
  std::string header(kMagic, 6);
  header += '\x01';
  header += '\x00';
  header += static_cast<char>(header_len & 0xff);
  header += static_cast<char>(header_len >> 8);
  header += dict;
  header.append(total_bytes - needed, ' ');
  header += '\n';
  TAC3D_DEMAND(header.size() == total_bytes);
  return header;
}

NpyWriter::NpyWriter(const std::string& path, NpyType type, std::vector<std::int64_t> item_shape)
    : path_(path), type_(type), item_shape_(std::move(item_shape)) {
  for (const std::int64_t d : item_shape_) {
    if (d < 0) throw Error(fmt::format("'{}': a row's dimension is {} < 0", path, d));
    item_elements_ *= d;
  }
  // Room for any row count, so Close rewrites the header in place.
  std::vector<std::int64_t> largest = {std::numeric_limits<std::int64_t>::max()};
  largest.insert(largest.end(), item_shape_.begin(), item_shape_.end());
  header_bytes_ = NpyHeader(type_, largest).size();
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) {
    throw Error(fmt::format("cannot create '{}': {}", path, std::strerror(errno)));
  }
  std::vector<std::int64_t> empty = {0};
  empty.insert(empty.end(), item_shape_.begin(), item_shape_.end());
  const std::string header = NpyHeader(type_, empty, header_bytes_);
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) {
    throw Error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
  }
}

NpyWriter::~NpyWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void NpyWriter::Append(const void* data, std::int64_t rows) {
  if (file_ == nullptr) throw Error(fmt::format("'{}' is closed", path_));
  TAC3D_DEMAND(rows >= 0);
  const std::size_t bytes = static_cast<std::size_t>(rows * item_elements_) * NpyItemBytes(type_);
  if (bytes > 0 && std::fwrite(data, 1, bytes, file_) != bytes) {
    throw Error(fmt::format("cannot write '{}': {}", path_, std::strerror(errno)));
  }
  rows_ += rows;
}

void NpyWriter::Close() {
  if (file_ == nullptr) throw Error(fmt::format("'{}' is closed", path_));
  std::vector<std::int64_t> shape = {rows_};
  shape.insert(shape.end(), item_shape_.begin(), item_shape_.end());
  const std::string header = NpyHeader(type_, shape, header_bytes_);
  std::FILE* file = file_;
  file_ = nullptr;
  const bool ok = std::fseek(file, 0, SEEK_SET) == 0 &&
                  std::fwrite(header.data(), 1, header.size(), file) == header.size() &&
                  std::fflush(file) == 0;
  const int error = errno;
  if (std::fclose(file) != 0 || !ok) {
    throw Error(fmt::format("cannot write '{}': {}", path_, std::strerror(ok ? errno : error)));
  }
}

void WriteNpy(const std::string& path,
              NpyType type,
              const std::vector<std::int64_t>& shape,
              const void* data) {
  if (shape.empty()) throw Error(fmt::format("'{}': an array needs at least one dimension", path));
  NpyWriter writer(path, type, std::vector<std::int64_t>(shape.begin() + 1, shape.end()));
  writer.Append(data, shape[0]);
  writer.Close();
}

}  // namespace tac3d
