#include "tac3d/imagefile/grey_image.h"

#include <gtest/gtest.h>

namespace tac3d {
namespace {

// BT.601 luma, the weights every frame source and the twin's colour camera use.
TEST(ConvertToGrey, ColourBecomesLumaAndGreyIsCopied) {
  cv::Mat grey;
  ConvertToGrey(cv::Mat(2, 2, CV_8UC3, cv::Scalar(200, 100, 50)), grey);  // B, G, R
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(grey.at<std::uint8_t>(1, 1), 96);  // 0.114 * 200 + 0.587 * 100 + 0.299 * 50 = 96.05
  ConvertToGrey(cv::Mat(2, 2, CV_8UC4, cv::Scalar(0, 0, 255, 255)), grey);
  EXPECT_EQ(grey.at<std::uint8_t>(0, 0), 76);  // pure red: 0.299 * 255
  const cv::Mat one(3, 4, CV_8UC1, cv::Scalar(17));
  ConvertToGrey(one, grey);
  EXPECT_EQ(grey.size(), one.size());
  EXPECT_EQ(grey.at<std::uint8_t>(2, 3), 17);
}

}  // namespace
}  // namespace tac3d
