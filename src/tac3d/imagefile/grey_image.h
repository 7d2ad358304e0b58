#pragma once

#include <opencv2/core/mat.hpp>

namespace tac3d {

/// The grey image every colour frame becomes before tracking (frame sources, the twin's colour
/// camera): BT.601 luma (OpenCV's COLOR_BGR2GRAY, 0.299 R + 0.587 G + 0.114 B) of a BGR or
/// BGRA image; any other image is copied as it is. Luma because compressed video and JPEG keep
/// it at full resolution (colour at half, 4:2:0) and the dots, black, are dark in every
/// channel under any colour of light (docs/real-images.md, "Colour").
void ConvertToGrey(const cv::Mat& image, cv::Mat& grey);

}  // namespace tac3d
