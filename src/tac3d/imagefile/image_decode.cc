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
// end-of-image marker (FF D9).
bool IsTruncatedJpeg(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;  // not a JPEG
  std::size_t last_sos = 0, last_eoi = 0;
  for (std::size_t i = 2; i + 1 < bytes.size(); ++i) {
    if (bytes[i] != 0xFF) continue;
    if (bytes[i + 1] == 0xDA) last_sos = i;
    if (bytes[i + 1] == 0xD9) last_eoi = i;
  }
  return last_sos == 0 || last_eoi < last_sos;
}

}  // namespace

std::vector<std::uint8_t> ReadImageFileBytes(const std::string& path) {
  const std::string bytes = ReadFileCapped(path, kMaxImageFileBytes, "image file");
  return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
}

DecodedImage DecodeGrayImage(const std::vector<std::uint8_t>& bytes, int max_width, int max_height) {
  DecodedImage decoded;
  if (bytes.empty()) {
    decoded.refusal = "the file is empty";
    return decoded;
  }
  if (IsTruncatedJpeg(bytes)) {
    decoded.refusal = "a truncated JPEG (no end of image after its last scan)";
    return decoded;
  }
  const std::optional<ImageDimensions> dims = ReadImageHeaderDimensions(bytes.data(), bytes.size());
  if (dims && (dims->width > max_width || dims->height > max_height)) {
    decoded.refusal = fmt::format("its header claims {} x {} pixels, more than the {} x {} accepted",
                                  dims->width, dims->height, max_width, max_height);
    return decoded;
  }
  try {
    decoded.image = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    decoded.refusal = fmt::format("the decoder refused it: {}", e.what());
    return decoded;
  }
  if (decoded.image.empty()) decoded.refusal = "not a readable image (corrupt or truncated)";
  return decoded;
}

}  // namespace tac3d
