#include "tac3d/source/threaded_capture.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "tac3d/imagefile/grey_image.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d {

struct ThreadedCapture::Shared {
  std::mutex mutex;
  std::condition_variable changed;
  cv::Mat latest;  // grey
  std::optional<cv::Rect> latest_decoded;
  double latest_s = 0.0;
  std::optional<cv::Rect> region;  // asked for by SetDecodeRegion
  bool has_new = false;
  bool failed = false;
  bool stop = false;
  bool exited = false;
  std::string error;
  std::thread thread;
};

ThreadedCapture::ThreadedCapture(std::string description, Grab grab, double timeout_s)
    : ThreadedCapture(
          std::move(description),
          [grab = std::move(grab)](const std::optional<cv::Rect>&, cv::Mat& image, std::optional<cv::Rect>& decoded,
                                   std::string& error) {
            decoded.reset();
            return grab(image, error);
          },
          timeout_s) {}

ThreadedCapture::ThreadedCapture(std::string description, DecodingGrab grab, double timeout_s)
    : description_(std::move(description)), timeout_s_(timeout_s), shared_(std::make_shared<Shared>()) {
  // The thread owns a reference to the shared state, so a thread left behind by the
  // destructor still has valid memory when its blocked read finally returns.
  shared_->thread = std::thread([shared = shared_, grab = std::move(grab)] {
    const auto start = std::chrono::steady_clock::now();
    cv::Mat image;
    std::optional<cv::Rect> region, decoded;
    while (true) {
      {
        std::lock_guard lock(shared->mutex);
        region = shared->region;
      }
      std::string error;
      const bool ok = grab(region, image, decoded, error);
      const double t = SecondsSince(start);
      std::lock_guard lock(shared->mutex);
      if (shared->stop) break;
      if (!ok || image.empty() || image.depth() != CV_8U) {
        shared->failed = true;
        shared->error = ok ? "the camera delivered an empty or non-8-bit image" : error;
        break;
      }
      ConvertToGrey(image, shared->latest);
      shared->latest_decoded = decoded;
      shared->latest_s = t;
      shared->has_new = true;
      shared->changed.notify_all();
    }
    std::lock_guard lock(shared->mutex);
    shared->exited = true;
    shared->changed.notify_all();
  });
}

ThreadedCapture::~ThreadedCapture() {
  std::unique_lock lock(shared_->mutex);
  shared_->stop = true;
  // A grab that returns within a frame period or two ends the thread; one stuck in the
  // driver is left behind rather than hanging the caller.
  const bool exited = shared_->changed.wait_for(lock, std::chrono::milliseconds(500),
                                                [&] { return shared_->exited; });
  lock.unlock();
  if (exited) {
    shared_->thread.join();
  } else {
    shared_->thread.detach();
  }
}

ReadStatus ThreadedCapture::Read(Frame& frame) {
  if (timed_out_) return ReadStatus::kFailed;  // last_error_ still says why
  std::unique_lock lock(shared_->mutex);
  const bool ready = shared_->changed.wait_for(
      lock, std::chrono::duration<double>(timeout_s_),
      [&] { return shared_->has_new || shared_->failed; });
  if (shared_->has_new) {
    shared_->latest.copyTo(frame.image);
    frame.decoded_region = shared_->latest_decoded;
    frame.timestamp_s = shared_->latest_s;
    frame.index = next_index_++;
    shared_->has_new = false;
    last_error_.clear();
    return ReadStatus::kOk;
  }
  last_error_ = ready ? fmt::format("{}: {}", description_, shared_->error)
                      : fmt::format("{}: no frame within {} s (unplugged or stalled?)",
                                    description_, timeout_s_);
  timed_out_ = !ready;
  return ReadStatus::kFailed;
}

void ThreadedCapture::SetDecodeRegion(const std::optional<cv::Rect>& region) {
  std::lock_guard lock(shared_->mutex);
  shared_->region = region;
}

}  // namespace tac3d
