#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace tac3d::testing {

/// The grey level of EncodeUniformImage's images.
constexpr int kUniformGrey = 77;

/// A width x height image of grey kUniformGrey, encoded in the format of `ext` (".png", ".jpg").
inline std::vector<std::uint8_t> EncodeUniformImage(const std::string& ext, int width, int height) {
  const cv::Mat image(height, width, CV_8UC1, cv::Scalar(kUniformGrey));
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes));
  return bytes;
}

}  // namespace tac3d::testing
