#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "tac3d/imagefile/image_decode.h"

namespace tac3d {

/// One camera image as the pipeline receives it.
struct Frame {
  cv::Mat image;              ///< CV_8UC1 (colour sources are converted to grey)
  double timestamp_s = 0.0;   ///< since the source was opened (or the file's own clock)
  std::int64_t index = 0;     ///< 0, 1, 2, ... in the order read
  /// The part of `image` decoded, when the source decoded only the region it was asked for
  /// (FrameSource::SetDecodeRegion); the other pixels are 0. nullopt: the whole image.
  std::optional<cv::Rect> decoded_region{};
};

enum class ReadStatus {
  kOk,        ///< `frame` holds a new image
  kBadFrame,  ///< this frame is unusable (a corrupt file, say); the next Read may succeed
  kEnd,       ///< no more frames (end of a file or folder)
  kFailed,    ///< the source broke (a camera unplugged): no further frames will come
};

/// Where images come from: a camera, a video file, an image folder, a twin dataset. The
/// pipeline reads them through this interface and does not know which one it has.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Reads the next frame into `frame` (its buffers are reused when they fit). Never throws
  /// for a frame's content; the reason for anything but kOk is in last_error().
  virtual ReadStatus Read(Frame& frame) = 0;
  /// What this source is, for messages ("camera /dev/video0 640x480 @ 30 fps").
  virtual std::string Describe() const = 0;
  /// The part of the images the caller reads from now on (its tracker's, MarkerTracker::
  /// CalcReadRegion), or nullopt for all of it, the default. A source of compressed frames (an
  /// MJPEG camera) may then decode only that part, saying so in Frame::decoded_region; the
  /// others ignore it.
  virtual void SetDecodeRegion(const std::optional<cv::Rect>& region) {}
  /// Why the last Read did not return kOk (empty after kOk).
  const std::string& last_error() const { return last_error_; }

 protected:
  std::string last_error_;
};

/// A V4L2 camera through OpenCV's VideoCapture.
struct CameraSourceOptions {
  std::string device = "/dev/video0";  ///< a device path, or its number ("0")
  int width = 640;
  int height = 480;
  double fps = 30.0;
  /// Manual exposure in the driver's units (V4L2: 100 us steps); empty = automatic.
  std::optional<double> exposure;
  /// The V4L2 pixel format asked of the driver, as its four-character code ("MJPG", "YUYV");
  /// empty: the driver's choice. A USB 2 camera gives 1920 x 1080 at 30 fps only as MJPEG.
  /// MJPEG frames are decoded straight to grey, the luma alone (at 1920 x 1080 about half the
  /// time of decoding to colour and converting: docs/real-sensors.md), and only the region set
  /// with SetDecodeRegion (JpegGreyDecoder).
  std::string pixel_format;

  /// @throws Error naming the field and its bound.
  void Validate() const;
};

/// @throws Error unless `code` is empty or a V4L2 four-character code (four letters or digits).
void ValidatePixelFormat(const std::string& code);

/// @throws Error naming `what` ("camera", "image folder") unless `fps` is in (0, 1000]: a
/// tactile camera runs at 30-90 fps, and 1e300 gave every image of a folder the timestamp 0.
void ValidateFrameRate(double fps, std::string_view what);

/// @throws Error (naming the device and what went wrong) if the camera cannot be opened
///   or does not deliver the requested resolution.
std::unique_ptr<FrameSource> OpenCamera(const CameraSourceOptions& options);

/// A video file (any container and codec OpenCV's backends read; MJPEG AVI always works).
/// Timestamps are the file's own presentation times.
/// @throws Error naming the file if it is missing or no backend can read it.
std::unique_ptr<FrameSource> OpenVideoFile(const std::string& path);

/// The PNG, JPEG, BMP or TIFF images of a folder, in lexicographic order of their names.
/// Timestamps are index / fps. A file that does not decode, or a JPEG cut short (which
/// would decode with grey rows), is a kBadFrame (named in last_error) and reading continues
/// with the next. So is a file whose header claims more than max_width x max_height pixels
/// (the camera's resolution), refused before it is decoded.
/// @throws Error if the folder is missing or holds no image file.
std::unique_ptr<FrameSource> OpenImageFolder(const std::string& path, double fps = 30.0,
                                             int max_width = kMaxImageSidePx, int max_height = kMaxImageSidePx);

/// The image files OpenImageFolder would read, sorted.
std::vector<std::string> ListImageFiles(const std::string& folder);

/// Opens what a command-line argument names: "camera:N" or "/dev/videoN" a camera (the
/// camera options' device replaced), a folder an image folder (timestamps index / the camera
/// options' fps; images larger than their width x height are bad frames), any other regular
/// file a video.
/// @throws Error as the opener does, if the path does not exist, or for "recording:FILE" (a
///   recording is read with RecordingReader, not as images).
std::unique_ptr<FrameSource> OpenFrameSource(const std::string& uri,
                                             const CameraSourceOptions& camera = {});

}  // namespace tac3d
