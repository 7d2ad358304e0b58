#include "tac3d/io/npy.h"

#include <fmt/format.h>

#include <bit>
#include <charconv>
#include <string_view>
#include <utility>
#include <cerrno>
#include <cstring>
#include <limits>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

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

// The header's dict as NumPy writes it (a Python literal): {'descr': '<f8', 'fortran_order':
// False, 'shape': (64, 400, 3), } with the keys in any order; every value is checked.
class HeaderParser {
 public:
  HeaderParser(std::string_view text, const std::string& path) : text_(text), path_(path) {}

  NpyArray Parse() {
    NpyArray array;
    bool has_descr = false, has_order = false, has_shape = false;
    Expect('{');
    while (!Accept('}')) {
      const std::string key = QuotedString();
      Expect(':');
      if (key == "descr") {
        array.type = ParseDescr(QuotedString());
        has_descr = true;
      } else if (key == "fortran_order") {
        array.fortran_order = Boolean();
        has_order = true;
      } else if (key == "shape") {
        array.shape = Shape();
        has_shape = true;
      } else {
        Fail(fmt::format("unknown key '{}'", key));
      }
      if (!Accept(',')) {
        Expect('}');
        break;
      }
    }
    SkipSpace();
    if (pos_ != text_.size()) Fail("text after the dict");
    if (!has_descr || !has_order || !has_shape) Fail("the dict lacks descr, fortran_order or shape");
    return array;
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(fmt::format("'{}': not an .npy header NumPy writes: {} (at byte {} of '{}')", path_,
                            what, pos_, text_));
  }
  void SkipSpace() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n')) ++pos_;
  }
  bool Accept(char c) {
    SkipSpace();
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  void Expect(char c) {
    if (!Accept(c)) Fail(fmt::format("'{}' expected", c));
  }
  std::string QuotedString() {
    SkipSpace();
    if (pos_ >= text_.size() || (text_[pos_] != '\'' && text_[pos_] != '"')) Fail("a quoted string expected");
    const char quote = text_[pos_++];
    const std::size_t end = text_.find(quote, pos_);
    if (end == std::string_view::npos) Fail("an unterminated string");
    const std::string s(text_.substr(pos_, end - pos_));
    pos_ = end + 1;
    return s;
  }
  bool Boolean() {
    SkipSpace();
    for (const auto& [word, value] : {std::pair{"True", true}, std::pair{"False", false}}) {
      if (text_.substr(pos_, std::strlen(word)) == word) {
        pos_ += std::strlen(word);
        return value;
      }
    }
    Fail("True or False expected");
  }
  std::vector<std::int64_t> Shape() {
    std::vector<std::int64_t> shape;
    Expect('(');
    while (!Accept(')')) {
      SkipSpace();
      std::int64_t d = 0;
      const char* begin = text_.data() + pos_;
      const auto [end, error] = std::from_chars(begin, text_.data() + text_.size(), d);
      if (error != std::errc() || d < 0) Fail("a dimension must be an integer >= 0 (and < 2^63)");
      pos_ += end - begin;
      shape.push_back(d);
      if (shape.size() > 32) Fail("more than 32 dimensions");
      if (!Accept(',')) {
        Expect(')');
        break;
      }
    }
    return shape;
  }
  NpyType ParseDescr(const std::string& descr) const {
    for (const NpyType type : {NpyType::kFloat64, NpyType::kInt64, NpyType::kUint32, NpyType::kBool}) {
      if (descr == NpyDescr(type)) return type;
    }
    throw Error(fmt::format("'{}': dtype '{}' is not one tac3d reads ('<f8', '<i8', '<u4', '|b1')",
                            path_, descr));
  }

  std::string_view text_;
  const std::string& path_;
  std::size_t pos_ = 0;
};

template <typename T>
std::vector<T> ValuesInCOrder(const NpyArray& array) {
  std::vector<T> file_order(static_cast<std::size_t>(array.elements()));
  std::memcpy(file_order.data(), array.data.data(), file_order.size() * sizeof(T));
  if (!array.fortran_order || array.shape.size() < 2) return file_order;
  // Fortran order: the first index varies fastest. Walk the C-order indices and map each.
  std::vector<T> values(file_order.size());
  const std::size_t dims = array.shape.size();
  std::vector<std::int64_t> index(dims, 0);
  for (std::size_t c = 0; c < values.size(); ++c) {
    std::int64_t f = 0;
    for (std::size_t k = dims; k-- > 0;) f = f * array.shape[k] + index[k];
    values[c] = file_order[static_cast<std::size_t>(f)];
    for (std::size_t k = dims; k-- > 0;) {
      if (++index[k] < array.shape[k]) break;
      index[k] = 0;
    }
  }
  return values;
}

}  // namespace

std::int64_t NpyArray::elements() const {
  std::int64_t n = 1;
  for (const std::int64_t d : shape) n *= d;
  return n;
}

std::vector<double> NpyArray::Float64Values() const {
  TAC3D_DEMAND(type == NpyType::kFloat64);
  return ValuesInCOrder<double>(*this);
}

std::vector<std::int64_t> NpyArray::Int64Values() const {
  TAC3D_DEMAND(type == NpyType::kInt64);
  return ValuesInCOrder<std::int64_t>(*this);
}

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
                      std::size_t total_bytes,
                      bool fortran_order) {
  const std::string dict = fmt::format("{{'descr': '{}', 'fortran_order': {}, 'shape': {}, }}",
                                       NpyDescr(type),
                                       fortran_order ? "True" : "False",
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

NpyArray ReadNpy(const std::string& path) {
  std::string bytes = ReadFileCapped(path, kMaxNpyFileBytes, ".npy file");
  if (bytes.size() < kPreambleBytes || bytes.compare(0, 6, kMagic, 6) != 0) {
    throw Error(fmt::format("'{}' is not an .npy file (no \\x93NUMPY magic)", path));
  }
  const int major = static_cast<std::uint8_t>(bytes[6]), minor = static_cast<std::uint8_t>(bytes[7]);
  if (major < 1 || major > 3 || minor != 0) {
    throw Error(fmt::format("'{}': .npy format version {}.{}: tac3d reads 1.0, 2.0 and 3.0", path, major, minor));
  }
  // Version 1 has a u16 header length, versions 2 and 3 a u32 (3 allows UTF-8 in the header).
  const std::size_t length_bytes = major == 1 ? 2 : 4;
  if (bytes.size() < 8 + length_bytes) throw Error(fmt::format("'{}': truncated in the .npy header", path));
  std::size_t header_len = 0;
  for (std::size_t i = length_bytes; i-- > 0;) header_len = header_len << 8 | static_cast<std::uint8_t>(bytes[8 + i]);
  const std::size_t data_begin = 8 + length_bytes + header_len;
  if (data_begin > bytes.size()) {
    throw Error(fmt::format("'{}': truncated: the .npy header says {} bytes, the file has {}", path,
                            header_len, bytes.size() - 8 - length_bytes));
  }
  NpyArray array =
      HeaderParser(std::string_view(bytes).substr(8 + length_bytes, header_len), path).Parse();
  const std::size_t item = NpyItemBytes(array.type);
  std::size_t expected = item;
  for (const std::int64_t d : array.shape) {
    if (d != 0 && expected > kMaxNpyFileBytes / static_cast<std::size_t>(d)) {
      throw Error(fmt::format("'{}': shape {} needs more than {} bytes", path, ShapeTuple(array.shape),
                              kMaxNpyFileBytes));
    }
    expected *= static_cast<std::size_t>(d);
  }
  const std::size_t held = bytes.size() - data_begin;
  if (held != expected) {
    throw Error(fmt::format("'{}': {} data bytes where shape {} of '{}' needs {}{}", path, held,
                            ShapeTuple(array.shape), NpyDescr(array.type), expected,
                            held < expected ? " (truncated)" : ""));
  }
  bytes.erase(0, data_begin);  // in place: a copy would hold the file twice
  array.data = std::move(bytes);
  return array;
}

void WriteNpy(const std::string& path, const NpyArray& array) {
  if (array.data.size() != static_cast<std::size_t>(array.elements()) * NpyItemBytes(array.type)) {
    throw Error(fmt::format("'{}': {} data bytes do not fill shape {} of '{}'", path, array.data.size(),
                            ShapeTuple(array.shape), NpyDescr(array.type)));
  }
  const std::string header = NpyHeader(array.type, array.shape, 0, array.fortran_order);
  WriteTextFileAtomically(path, header + array.data);  // bytes as they are
}

}  // namespace tac3d
