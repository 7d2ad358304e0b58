#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace tac3d {

/// Writes `image` as the file `path`, encoded as its extension says (".png", ".jpg"), through
/// WriteFileAtomically: never through a link planted at the path or a temporary name, never
/// over a device, and the final name only ever holds a whole file.
/// @throws Error naming the file if the image cannot be encoded or written.
void WriteImageFile(const std::string& path, const cv::Mat& image);

}  // namespace tac3d
