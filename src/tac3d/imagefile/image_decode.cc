#include "tac3d/imagefile/image_decode.h"

#include <optional>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/imagefile/image_header.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

// A JPEG cut short still decodes (libjpeg warns and fills the missing rows with grey), so
// the file itself is checked: the main image's data begins at the last start-of-scan
// marker (FF DA; a thumbnail's and a progressive file's earlier scans come before it, and
// FF never starts a marker inside entropy-coded data) and must be followed by an
// end-of-image marker (FF D9). Searched from the end, where a whole file's end of image is,
// so a camera's frame costs a few bytes of search, not all of them.
bool IsTruncatedJpeg(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;  // not a JPEG
  const auto marker_at = [&](std::size_t i, std::uint8_t code) { return bytes[i] == 0xFF && bytes[i + 1] == code; };
  std::size_t last_eoi = bytes.size() - 2;
  while (last_eoi >= 2 && !marker_at(last_eoi, 0xD9)) {
    if (marker_at(last_eoi, 0xDA)) return true;  // the last scan has no end of image after it
    --last_eoi;
  }
  if (last_eoi < 2) return true;  // no end of image at all
  for (std::size_t i = 2; i < last_eoi; ++i) {
    if (marker_at(i, 0xDA)) return false;
  }
  return true;  // no scan before the end of image
}

}  // namespace

std::vector<std::uint8_t> ReadImageFileBytes(const std::string& path) {
  const std::string bytes = ReadFileCapped(path, kMaxImageFileBytes, "image file");
  return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
}

namespace internal {

std::string RefusalBeforeDecoding(const std::vector<std::uint8_t>& bytes, int max_width, int max_height) {
  if (bytes.empty()) return "the file is empty";
  if (IsTruncatedJpeg(bytes)) return "a truncated JPEG (no end of image after its last scan)";
  const std::optional<ImageDimensions> dims = ReadImageHeaderDimensions(bytes.data(), bytes.size());
  if (dims && (dims->width > max_width || dims->height > max_height)) {
    return fmt::format("its header claims {} x {} pixels, more than the {} x {} accepted", dims->width,
                       dims->height, max_width, max_height);
  }
  return "";
}

}  // namespace internal

DecodedImage DecodeGrayImage(const std::vector<std::uint8_t>& bytes, int max_width, int max_height) {
  DecodedImage decoded;
  decoded.refusal = internal::RefusalBeforeDecoding(bytes, max_width, max_height);
  if (!decoded.refusal.empty()) return decoded;
  try {
    decoded.image = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    decoded.refusal = fmt::format("the decoder refused it: {}", e.what());
    return decoded;
  }
  if (decoded.image.empty()) decoded.refusal = internal::kUnreadableImage;
  return decoded;
}

}  // namespace tac3d
