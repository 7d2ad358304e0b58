#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <vector>

namespace tac3d {

static_assert(std::endian::native == std::endian::little, "CDR and MCAP are written little-endian");

/// Serializes one ROS 2 message as classic CDR (XCDR1), little-endian: the 4-byte encapsulation
/// header 00 01 00 00, then the fields, each aligned to its size counted from after the header.
class CdrWriter {
 public:
  CdrWriter() : bytes_{0x00, 0x01, 0x00, 0x00} {}

  template <typename T>
  void Put(T value) {
    Align(sizeof(T));
    Append(&value, sizeof(T));
  }
  /// uint32 length including the NUL, the bytes, the NUL.
  void String(std::string_view s) {
    Put(static_cast<std::uint32_t>(s.size() + 1));
    Append(s.data(), s.size());
    bytes_.push_back(0);
  }
  /// A sequence's uint32 element count (the elements follow).
  void Count(std::size_t n) { Put(static_cast<std::uint32_t>(n)); }
  /// uint8[]: the count, then the bytes.
  void Bytes(const void* data, std::size_t size) {
    Count(size);
    Append(data, size);
  }

  const std::vector<std::uint8_t>& bytes() const { return bytes_; }
  std::vector<std::uint8_t> Take() { return std::move(bytes_); }

 private:
  void Align(std::size_t n) {
    while ((bytes_.size() - 4) % n != 0) bytes_.push_back(0);
  }
  void Append(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  std::vector<std::uint8_t> bytes_;
};

}  // namespace tac3d
