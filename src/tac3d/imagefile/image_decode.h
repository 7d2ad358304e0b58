#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace tac3d {

/// The largest image side tac3d reads or writes, in pixels (cameras, renders, image files).
inline constexpr int kMaxImageSidePx = 8192;

/// The largest image file tac3d reads (bytes): an uncompressed 8192 x 8192 colour BMP is 201 MB.
inline constexpr std::size_t kMaxImageFileBytes = std::size_t{256} << 20;

/// The bytes of an image file, for DecodeGrayImage: a regular file (a FIFO would block, a device
/// never end) of at most kMaxImageFileBytes. @throws Error naming the file otherwise.
std::vector<std::uint8_t> ReadImageFileBytes(const std::string& path);

/// An image file decoded, or the reason it was refused.
struct DecodedImage {
  cv::Mat image;        ///< 8-bit grey; empty when refused
  std::string refusal;  ///< why it was refused (no file name); empty when decoded
};

/// Decodes an image file's bytes (PNG, JPEG, BMP, TIFF, PGM) to 8-bit grey. Refused, never
/// thrown: no bytes, a JPEG cut short (which would decode with grey rows), a header that
/// claims more than max_width x max_height pixels (checked before decoding, because a decoder
/// allocates what a corrupt header claims), and whatever the decoder refuses.
DecodedImage DecodeGrayImage(const std::vector<std::uint8_t>& bytes, int max_width, int max_height);

namespace internal {

/// DecodeGrayImage's refusal of a file a decoder did not read.
inline constexpr const char* kUnreadableImage = "not a readable image (corrupt or truncated)";

/// DecodeGrayImage's refusals made before decoding (no bytes, a JPEG cut short, a header over the
/// limit), or "" for bytes to hand to a decoder.
std::string RefusalBeforeDecoding(const std::vector<std::uint8_t>& bytes, int max_width, int max_height);

}  // namespace internal

}  // namespace tac3d
