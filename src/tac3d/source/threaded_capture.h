#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "tac3d/source/frame_source.h"

namespace tac3d {

/// Runs a blocking grab function (a camera driver's read) on its own thread and hands the
/// newest image to Read, which waits at most `timeout_s`. A driver that stops returning
/// (a camera unplugged mid-run can leave a read blocked) then costs one timeout, not a hang:
/// Read reports kFailed and the destructor leaves the stuck thread behind instead of
/// joining it. When the pipeline is slower than the camera, older images are dropped
/// (the newest is what a controller wants).
class ThreadedCapture : public FrameSource {
 public:
  /// Fills the image (any 8-bit type) and returns true, or returns false with a reason.
  using Grab = std::function<bool(cv::Mat& image, std::string& error)>;
  /// A grab that decodes compressed frames (a camera's MJPEG): given the region last set with
  /// SetDecodeRegion, fills the image and the part of it decoded (Frame::decoded_region).
  using DecodingGrab = std::function<bool(const std::optional<cv::Rect>& region, cv::Mat& image,
                                          std::optional<cv::Rect>& decoded, std::string& error)>;

  ThreadedCapture(std::string description, Grab grab, double timeout_s);
  /// Decoding on the grab's thread too: the next frame is decoded while the caller processes this
  /// one, with the region the caller set after the one before (a frame behind).
  ThreadedCapture(std::string description, DecodingGrab grab, double timeout_s);
  ~ThreadedCapture() override;

  ReadStatus Read(Frame& frame) override;
  void SetDecodeRegion(const std::optional<cv::Rect>& region) override;
  std::string Describe() const override { return description_; }

 private:
  struct Shared;
  std::string description_;
  double timeout_s_;
  std::shared_ptr<Shared> shared_;
  std::int64_t next_index_ = 0;
  bool timed_out_ = false;  // a stalled driver is not waited for twice
};

}  // namespace tac3d
