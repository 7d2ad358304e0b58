#pragma once

// The viewer's image message decoded back into its image, for the tests of what it shows
// (web/web_server_test, cli/view_data_test). Header-only: its users link OpenCV's imgcodecs
// through tac3d::web.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/imgcodecs.hpp>

namespace tac3d::testing {

/// The JPEG of an image message ({"type":"image",...,"jpeg":"<base64>"}) decoded as 8-bit BGR;
/// empty when the message has no "jpeg" or it does not decode.
inline cv::Mat DecodeImageMessage(const std::string& message) {
  const std::string key = "\"jpeg\":\"";
  const size_t begin = message.find(key);
  if (begin == std::string::npos) return {};
  const size_t end = message.find('"', begin + key.size());
  if (end == std::string::npos) return {};
  std::array<int, 256> value;
  value.fill(-1);
  const std::string table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (size_t i = 0; i < table.size(); ++i) value[static_cast<unsigned char>(table[i])] = static_cast<int>(i);
  std::vector<std::uint8_t> bytes;
  std::uint32_t bits = 0;
  int count = 0;
  for (size_t i = begin + key.size(); i < end; ++i) {
    const int v = value[static_cast<unsigned char>(message[i])];
    if (v < 0) break;  // '=' padding
    bits = (bits << 6) | static_cast<std::uint32_t>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      bytes.push_back(static_cast<std::uint8_t>((bits >> count) & 0xff));
    }
  }
  return cv::imdecode(bytes, cv::IMREAD_COLOR);
}

/// A pixel (BGR) clearly in the marker colours of the viewer's image: green (tracked) or red
/// (lost); grey, the camera's, is neither.
inline bool IsMarkerGreen(const cv::Vec3b& bgr) { return bgr[1] >= bgr[2] + 40 && bgr[1] >= bgr[0] + 40; }
inline bool IsMarkerRed(const cv::Vec3b& bgr) { return bgr[2] >= bgr[1] + 40 && bgr[2] >= bgr[0] + 40; }

/// How many pixels of a BGR image within `radius` px (a square) of `at` (px) satisfy `is`.
template <typename Predicate>
int CountPixelsNear(const cv::Mat& bgr, const Eigen::Vector2d& at, int radius, Predicate is) {
  int count = 0;
  const int cx = static_cast<int>(std::lround(at.x())), cy = static_cast<int>(std::lround(at.y()));
  for (int y = std::max(0, cy - radius); y <= std::min(bgr.rows - 1, cy + radius); ++y) {
    for (int x = std::max(0, cx - radius); x <= std::min(bgr.cols - 1, cx + radius); ++x) {
      count += is(bgr.at<cv::Vec3b>(y, x)) ? 1 : 0;
    }
  }
  return count;
}

/// The pixels of a BGR image in either marker colour.
inline int CountMarkerPixels(const cv::Mat& bgr) {
  int count = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      count += IsMarkerGreen(p) || IsMarkerRed(p) ? 1 : 0;
    }
  }
  return count;
}

}  // namespace tac3d::testing
