#include "tac3d/imagefile/image_header.h"

#include <cctype>
#include <cstdlib>
#include <cstring>

namespace tac3d {
namespace {

std::uint32_t BigEndian32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         p[3];
}
std::uint16_t BigEndian16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

std::optional<ImageDimensions> Png(const std::uint8_t* d, std::size_t n) {
  // Signature (8 bytes), then the IHDR chunk: length (4), type (4), width (4), height (4).
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (n < 24 || std::memcmp(d, kSignature, 8) != 0 || std::memcmp(d + 12, "IHDR", 4) != 0)
    return std::nullopt;
  return ImageDimensions{BigEndian32(d + 16), BigEndian32(d + 20)};
}

std::optional<ImageDimensions> Jpeg(const std::uint8_t* d, std::size_t n) {
  // Walk the marker segments to the first start-of-frame (SOF0-SOF15 but DHT C4, JPG C8, DAC CC).
  std::size_t i = 2;
  while (i + 9 <= n) {
    if (d[i] != 0xFF) return std::nullopt;
    const std::uint8_t marker = d[i + 1];
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      return ImageDimensions{BigEndian16(d + i + 7), BigEndian16(d + i + 5)};
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
      i += 2;  // markers without a length
      continue;
    }
    i += 2 + BigEndian16(d + i + 2);
  }
  return std::nullopt;
}

std::optional<ImageDimensions> Bmp(const std::uint8_t* d, std::size_t n) {
  if (n < 26 || d[0] != 'B' || d[1] != 'M') return std::nullopt;
  std::int32_t width = 0, height = 0;
  std::memcpy(&width, d + 18, 4);  // little-endian, as x86 and ARM read it
  std::memcpy(&height, d + 22, 4);
  return ImageDimensions{std::llabs(static_cast<long long>(width)),
                         std::llabs(static_cast<long long>(height))};
}

std::optional<ImageDimensions> Tiff(const std::uint8_t* d, std::size_t n) {
  if (n < 8) return std::nullopt;
  const bool little = d[0] == 'I' && d[1] == 'I' && d[2] == 42 && d[3] == 0;
  const bool big = d[0] == 'M' && d[1] == 'M' && d[2] == 0 && d[3] == 42;
  if (!little && !big) return std::nullopt;
  const auto u16 = [&](std::size_t at) -> std::uint32_t {
    return little ? d[at] | (d[at + 1] << 8) : BigEndian16(d + at);
  };
  const auto u32 = [&](std::size_t at) -> std::uint32_t {
    return little ? d[at] | (d[at + 1] << 8) | (d[at + 2] << 16) | (std::uint32_t{d[at + 3]} << 24)
                  : BigEndian32(d + at);
  };
  const std::size_t ifd = u32(4);
  if (ifd + 2 > n) return std::nullopt;
  const std::uint32_t entries = u16(ifd);
  ImageDimensions dims;
  for (std::uint32_t e = 0; e < entries; ++e) {
    const std::size_t at = ifd + 2 + 12 * std::size_t{e};
    if (at + 12 > n) return std::nullopt;
    const std::uint32_t tag = u16(at), type = u16(at + 2);
    const std::uint32_t value = type == 3 ? u16(at + 8) : u32(at + 8);  // SHORT or LONG
    if (tag == 256) dims.width = value;
    if (tag == 257) dims.height = value;
  }
  if (dims.width == 0 || dims.height == 0) return std::nullopt;
  return dims;
}

// Netpbm: "P5" (or P2, P3, P6), whitespace and comments, width, height.
std::optional<ImageDimensions> Pnm(const std::uint8_t* d, std::size_t n) {
  if (n < 3 || d[0] != 'P' || d[1] < '1' || d[1] > '6') return std::nullopt;
  std::size_t i = 2;
  std::int64_t values[2] = {0, 0};
  for (std::int64_t& v : values) {
    while (i < n && (std::isspace(d[i]) || d[i] == '#')) {
      if (d[i] == '#') {
        while (i < n && d[i] != '\n') ++i;
      } else {
        ++i;
      }
    }
    if (i >= n || !std::isdigit(d[i])) return std::nullopt;
    while (i < n && std::isdigit(d[i]) && v < (std::int64_t{1} << 40)) v = 10 * v + (d[i++] - '0');
  }
  return ImageDimensions{values[0], values[1]};
}

}  // namespace

std::optional<ImageDimensions> ReadImageHeaderDimensions(const std::uint8_t* data,
                                                         std::size_t size) {
  if (size >= 2 && data[0] == 0xFF && data[1] == 0xD8) return Jpeg(data, size);
  for (auto reader : {Png, Bmp, Tiff, Pnm}) {
    if (auto dims = reader(data, size)) return dims;
  }
  return std::nullopt;
}

}  // namespace tac3d
