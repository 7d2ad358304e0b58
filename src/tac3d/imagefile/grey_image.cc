#include "tac3d/imagefile/grey_image.h"

#include <opencv2/imgproc.hpp>

namespace tac3d {

void ConvertToGrey(const cv::Mat& image, cv::Mat& grey) {
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    image.copyTo(grey);
  }
}

}  // namespace tac3d
