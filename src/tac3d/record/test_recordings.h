#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/record/recording.h"

namespace tac3d::testing {

/// A rows x cols 8-bit image of uniform noise, the same for the same seed.
inline cv::Mat RandomImage(int seed, int rows, int cols) {
  cv::Mat image(rows, cols, CV_8UC1);
  cv::theRNG().state = seed;
  cv::randu(image, 0, 256);
  return image;
}

/// Writes synthetic frames 0..n-1 (timestamps i / 90 s) to `path`, every third with
/// RandomImage(i, rows, cols); returns the path.
inline std::string WriteSyntheticRecording(const std::string& path, int n, int rows, int cols) {
  RecordingWriter writer(path);
  for (int i = 0; i < n; ++i) {
    writer.Write(MakeSyntheticTactileFrame("AD2-0065L", i),
                 i % 3 == 0 ? RandomImage(i, rows, cols) : cv::Mat());
  }
  return path;
}

}  // namespace tac3d::testing
