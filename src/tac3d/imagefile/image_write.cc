#include "tac3d/imagefile/image_write.h"

#include <filesystem>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {

void WriteImageFile(const std::string& path, const cv::Mat& image) {
  // Encoded in memory: the temporary's name has no extension for OpenCV to choose a format by.
  std::vector<std::uint8_t> bytes;
  bool encoded = false;
  try {
    encoded = !image.empty() && cv::imencode(std::filesystem::path(path).extension().string(), image, bytes);
  } catch (const cv::Exception& e) {
    throw Error(fmt::format("image '{}' cannot be encoded: {}", path, e.what()));
  }
  if (!encoded) throw Error(fmt::format("image '{}' cannot be encoded (an empty image, or no such format)", path));
  WriteTextFileAtomically(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace tac3d
