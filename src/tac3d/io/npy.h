#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace tac3d {

/// The element types NpyWriter writes, with their NumPy dtype strings.
enum class NpyType {
  kFloat64,  ///< '<f8'
  kInt64,    ///< '<i8'
  kUint32,   ///< '<u4'
  kBool,     ///< '|b1', one byte a value, 0 or 1
};

/// The dtype string of a type in an .npy header ("<f8").
const char* NpyDescr(NpyType type);
/// Bytes per element.
std::size_t NpyItemBytes(NpyType type);

/// The .npy header, format version 1.0 (the NumPy format's NEP 1): the magic "\x93NUMPY",
/// version bytes 1 0, a u16 little-endian length, then the dict
/// `{'descr': '<f8', 'fortran_order': False, 'shape': (T, N, 3), }` padded with spaces and
/// ended by '\n' so that the whole header is a multiple of 64 bytes long.
/// @param total_bytes the header's length, or 0 for the shortest multiple of 64 that holds it.
/// @throws Error if the dict does not fit in total_bytes, total_bytes is not a multiple of 64,
/// or a dimension is negative.
/// @param fortran_order whether the data that follows is in column-major order.
std::string NpyHeader(NpyType type,
                      const std::vector<std::int64_t>& shape,
                      std::size_t total_bytes = 0,
                      bool fortran_order = false);

/// Streams an array of shape (T, item_shape...), C order, into an .npy file whose T grows
/// with each Append: the header is written first with room for any T (NumPy does the same to
/// grow an array in place) and rewritten with the final T by Close.
class NpyWriter {
 public:
  /// Creates (truncates) `path`. @param item_shape the shape of one row (empty for a 1-D array).
  /// @throws Error if the file cannot be created or a dimension is negative.
  NpyWriter(const std::string& path, NpyType type, std::vector<std::int64_t> item_shape);
  ~NpyWriter();
  NpyWriter(const NpyWriter&) = delete;
  NpyWriter& operator=(const NpyWriter&) = delete;

  /// Appends `rows` rows from `data` (rows * the item's element count values of the writer's
  /// type, little-endian; for kBool, bytes 0 or 1).
  /// @throws Error if the writer is closed or the write fails.
  void Append(const void* data, std::int64_t rows = 1);
  /// Rewrites the header with the number of rows appended, flushes and closes the file.
  /// @throws Error if a write fails.
  void Close();

  std::int64_t rows() const { return rows_; }
  std::int64_t item_elements() const { return item_elements_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  NpyType type_;
  std::vector<std::int64_t> item_shape_;
  std::int64_t item_elements_ = 1;
  std::size_t header_bytes_ = 0;
  std::int64_t rows_ = 0;
  std::FILE* file_ = nullptr;
};

/// Writes a whole array of the given shape (C order) to `path` in one go; `data` holds the
/// product of `shape` values. @throws Error as NpyWriter does, or if shape is empty.
void WriteNpy(const std::string& path,
              NpyType type,
              const std::vector<std::int64_t>& shape,
              const void* data);

/// A whole .npy array as read: its element type, shape, order and data bytes (little-endian,
/// in the file's order).
struct NpyArray {
  NpyType type = NpyType::kFloat64;
  std::vector<std::int64_t> shape;
  bool fortran_order = false;
  std::string data;

  std::int64_t elements() const;
  /// The values in C (row-major) order, whatever the file's order. @pre type is kFloat64.
  std::vector<double> Float64Values() const;
  /// As Float64Values, for kInt64.
  std::vector<std::int64_t> Int64Values() const;
  bool operator==(const NpyArray&) const = default;
};

/// The largest .npy file ReadNpy reads (a 30 Hz recording of 400 markers runs ~170 MB an hour
/// a field).
inline constexpr std::size_t kMaxNpyFileBytes = std::size_t{2} << 30;

/// Reads an .npy file of format version 1.0, 2.0 or 3.0 (NumPy's NEP 1) holding '<f8', '<i8',
/// '<u4' or '|b1' values in C or Fortran order.
/// @throws Error naming the file and what is wrong: not an .npy file, another version, a
///   header that is not the dict NumPy writes, another dtype (big-endian, objects, ...), a
///   negative or overflowing shape, or data bytes that are not exactly what the shape needs
///   (a truncated file).
NpyArray ReadNpy(const std::string& path);

/// Writes `array` as an .npy file of version 1.0 (its data bytes as they are, with its order);
/// ReadNpy reads it back equal. @throws Error if the data's size does not match the shape or
/// the file cannot be written.
void WriteNpy(const std::string& path, const NpyArray& array);

}  // namespace tac3d
