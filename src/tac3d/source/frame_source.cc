#include "tac3d/source/frame_source.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>
#include <opencv2/videoio.hpp>

#include "tac3d/imagefile/grey_image.h"
#include "tac3d/imagefile/image_decode.h"
#include "tac3d/imagefile/jpeg_decoder.h"
#include "tac3d/source/threaded_capture.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

namespace fs = std::filesystem;

// A camera's driver is given this long to deliver each frame before the source fails.
constexpr double kCameraTimeoutS = 2.0;
constexpr double kMaxFps = 1000.0;  // ValidateFrameRate's bound

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool IsImageFile(const fs::path& path) {
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm"};
  const std::string ext = Lower(path.extension().string());
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&](const char* e) { return ext == e; });
}

int FourCc(const std::string& code) { return cv::VideoWriter::fourcc(code[0], code[1], code[2], code[3]); }

std::string FourCcName(int code) {
  std::string name(4, ' ');
  for (int i = 0; i < 4; ++i) name[i] = static_cast<char>((code >> (8 * i)) & 0xff);
  return name;
}

// Why a camera's read failed: the device file tells an unplugged camera from a stalled driver.
std::string CameraReadFailure(const std::string& path) {
  return fs::exists(path) ? "the driver stopped delivering frames" : "the device is gone (unplugged)";
}

// A camera streaming MJPEG: each frame's JPEG, as the driver delivered it, decoded to grey
// where the caller reads (JpegGreyDecoder). A frame that does not decode (a USB transfer cut
// short) is skipped; so many in a row that the stream is not MJPEG fails the source.
class MjpegGrab {
 public:
  MjpegGrab(std::shared_ptr<cv::VideoCapture> capture, std::string path, int width, int height)
      : capture_(std::move(capture)), path_(std::move(path)), width_(width), height_(height),
        decoder_(std::make_shared<JpegGreyDecoder>()) {}

  bool operator()(const std::optional<cv::Rect>& region, cv::Mat& image, std::optional<cv::Rect>& decoded,
                  std::string& error) {
    constexpr int kMaxUndecodable = 30;
    for (int undecodable = 0; undecodable < kMaxUndecodable; ++undecodable) {
      if (!capture_->read(raw_)) {
        error = CameraReadFailure(path_);
        return false;
      }
      bytes_.assign(raw_.datastart, raw_.dataend);
      const JpegDecodeResult result = decoder_->Decode(bytes_, width_, height_, region, image);
      if (result.refusal.empty()) {
        decoded = region ? std::optional<cv::Rect>(result.decoded) : std::nullopt;
        return true;
      }
      error = result.refusal;
    }
    error = fmt::format("{} MJPEG frames in a row did not decode (last: {})", kMaxUndecodable, error);
    return false;
  }

 private:
  std::shared_ptr<cv::VideoCapture> capture_;
  std::string path_;
  int width_;
  int height_;
  std::shared_ptr<JpegGreyDecoder> decoder_;  // shared: std::function copies the grab
  cv::Mat raw_;
  std::vector<std::uint8_t> bytes_;
};

// "0" -> "/dev/video0"; a path stays as it is.
std::string DevicePath(const std::string& device) {
  const bool number = !device.empty() && std::all_of(device.begin(), device.end(), ::isdigit);
  return number ? "/dev/video" + device : device;
}

class VideoFileSource : public FrameSource {
 public:
  explicit VideoFileSource(const std::string& path) : path_(path) {
    if (!fs::exists(path)) throw Error(fmt::format("video file '{}' does not exist", path));
    if (!fs::is_regular_file(path)) throw Error(fmt::format("video file '{}' is not a regular file", path));
    // FFmpeg reads every common container; OpenCV's own MJPEG reader the AVIs it writes.
    // GStreamer is not tried: on a file it cannot read it prints pages of warnings.
    if (!capture_.open(path, cv::CAP_FFMPEG) && !capture_.open(path, cv::CAP_OPENCV_MJPEG)) {
      throw Error(fmt::format("video file '{}': not a video FFmpeg or the MJPEG reader can read", path));
    }
  }
  ReadStatus Read(Frame& frame) override {
    if (!capture_.read(bgr_) || bgr_.empty()) {
      last_error_ = fmt::format("{}: end of the video after {} frames", path_, next_index_);
      return ReadStatus::kEnd;
    }
    ConvertToGrey(bgr_, frame.image);
    frame.timestamp_s = capture_.get(cv::CAP_PROP_POS_MSEC) / 1000.0;
    frame.index = next_index_++;
    last_error_.clear();
    return ReadStatus::kOk;
  }
  std::string Describe() const override { return fmt::format("video file {}", path_); }

 private:
  std::string path_;
  cv::VideoCapture capture_;
  cv::Mat bgr_;
  std::int64_t next_index_ = 0;
};

class ImageFolderSource : public FrameSource {
 public:
  ImageFolderSource(const std::string& folder, double fps, int max_width, int max_height)
      : folder_(folder), files_(ListImageFiles(folder)), fps_(fps), max_width_(max_width),
        max_height_(max_height) {
    if (files_.empty()) throw Error(fmt::format("image folder '{}' holds no image file", folder));
    ValidateFrameRate(fps, "image folder");
    if (max_width < 1 || max_height < 1) {
      throw Error(fmt::format("image folder: the largest image {} x {} must be at least 1 x 1", max_width,
                              max_height));
    }
  }
  ReadStatus Read(Frame& frame) override {
    if (next_ >= files_.size()) {
      last_error_ = fmt::format("{}: all {} images read", folder_, files_.size());
      return ReadStatus::kEnd;
    }
    const std::string& file = files_[next_];
    frame.index = static_cast<std::int64_t>(next_);
    frame.timestamp_s = static_cast<double>(next_) / fps_;
    ++next_;
    try {
      bytes_ = ReadImageFileBytes(file);
    } catch (const Error& e) {
      last_error_ = e.what();
      return ReadStatus::kBadFrame;
    }
    DecodedImage decoded = DecodeGrayImage(bytes_, max_width_, max_height_);
    if (decoded.image.empty()) {
      last_error_ = fmt::format("'{}': {}", file, decoded.refusal);
      return ReadStatus::kBadFrame;
    }
    frame.image = std::move(decoded.image);
    last_error_.clear();
    return ReadStatus::kOk;
  }
  std::string Describe() const override {
    return fmt::format("image folder {} ({} images at {} fps)", folder_, files_.size(), fps_);
  }

 private:
  std::string folder_;
  std::vector<std::string> files_;
  double fps_;
  int max_width_;
  int max_height_;
  size_t next_ = 0;
  std::vector<std::uint8_t> bytes_;  // the file being decoded (reused)
};

}  // namespace

void CameraSourceOptions::Validate() const {
  if (device.empty()) throw Error("camera: device must not be empty");
  if (width < 16 || width > kMaxImageSidePx || height < 16 || height > kMaxImageSidePx) {
    throw Error(fmt::format("camera: width x height = {} x {} must be within 16..{}", width, height,
                            kMaxImageSidePx));
  }
  ValidateFrameRate(fps, "camera");
  if (exposure && !(*exposure > 0)) {
    throw Error(fmt::format("camera: exposure = {} must be > 0 (omit it for automatic)", *exposure));
  }
  ValidatePixelFormat(pixel_format);
}

void ValidateFrameRate(double fps, std::string_view what) {
  if (!(fps > 0 && fps <= kMaxFps)) {
    throw Error(fmt::format("{}: fps = {} must be in (0, {}]", what, fps, kMaxFps));
  }
}

void ValidatePixelFormat(const std::string& code) {
  if (!code.empty() && (code.size() != 4 || !std::all_of(code.begin(), code.end(), ::isalnum))) {
    throw Error(fmt::format("camera: pixel format '{}' is not a V4L2 four-character code such as MJPG or YUYV "
                            "(`v4l2-ctl --list-formats-ext` lists a camera's)",
                            code));
  }
}

std::unique_ptr<FrameSource> OpenCamera(const CameraSourceOptions& options) {
  options.Validate();
  const std::string path = DevicePath(options.device);
  if (!fs::exists(path)) {
    throw Error(fmt::format("camera {}: no such device (is it plugged in? `ls /dev/video*` lists cameras)",
                            path));
  }
  auto capture = std::make_shared<cv::VideoCapture>();
  if (!capture->open(path, cv::CAP_V4L2) || !capture->isOpened()) {
    throw Error(fmt::format("camera {}: the V4L2 driver refused to open it (in use by another "
                            "program, or no permission: is the user in group 'video'?)", path));
  }
  if (!options.pixel_format.empty()) capture->set(cv::CAP_PROP_FOURCC, FourCc(options.pixel_format));
  capture->set(cv::CAP_PROP_FRAME_WIDTH, options.width);
  capture->set(cv::CAP_PROP_FRAME_HEIGHT, options.height);
  capture->set(cv::CAP_PROP_FPS, options.fps);
  if (options.exposure) {
    capture->set(cv::CAP_PROP_AUTO_EXPOSURE, 1);  // V4L2: 1 = manual
    capture->set(cv::CAP_PROP_EXPOSURE, *options.exposure);
  }
  const int width = static_cast<int>(capture->get(cv::CAP_PROP_FRAME_WIDTH));
  const int height = static_cast<int>(capture->get(cv::CAP_PROP_FRAME_HEIGHT));
  if (width != options.width || height != options.height) {
    throw Error(fmt::format("camera {}: asked for {} x {}, the driver gives {} x {}", path,
                            options.width, options.height, width, height));
  }
  const std::string format = FourCcName(static_cast<int>(capture->get(cv::CAP_PROP_FOURCC)));
  if (!options.pixel_format.empty() && format != options.pixel_format) {
    throw Error(fmt::format("camera {}: asked for pixel format {}, the driver gives {}", path,
                            options.pixel_format, format));
  }
  const std::string description =
      fmt::format("camera {} {}x{} {} @ {} fps", path, width, height, format, capture->get(cv::CAP_PROP_FPS));
  if (format == "MJPG" && capture->set(cv::CAP_PROP_CONVERT_RGB, 0)) {
    return std::make_unique<ThreadedCapture>(description, ThreadedCapture::DecodingGrab(MjpegGrab(capture, path, width, height)),
                                             kCameraTimeoutS);
  }
  auto grab = [capture, path](cv::Mat& image, std::string& error) {
    if (capture->read(image)) return true;
    error = CameraReadFailure(path);
    return false;
  };
  return std::make_unique<ThreadedCapture>(description, grab, kCameraTimeoutS);
}

std::unique_ptr<FrameSource> OpenVideoFile(const std::string& path) {
  return std::make_unique<VideoFileSource>(path);
}

std::vector<std::string> ListImageFiles(const std::string& folder) {
  if (!fs::is_directory(folder)) throw Error(fmt::format("image folder '{}' does not exist", folder));
  std::vector<std::string> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && IsImageFile(entry.path())) files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::unique_ptr<FrameSource> OpenImageFolder(const std::string& path, double fps, int max_width,
                                             int max_height) {
  return std::make_unique<ImageFolderSource>(path, fps, max_width, max_height);
}

std::unique_ptr<FrameSource> OpenFrameSource(const std::string& uri, const CameraSourceOptions& camera) {
  if (uri.rfind("recording:", 0) == 0) {
    throw Error(fmt::format("frame source '{}': a recording holds processed frames, not camera "
                            "images; read it with RecordingReader (Python: tac3d.RecordingReader), "
                            "or replay it with `tac3d run --source {}`",
                            uri, uri));
  }
  CameraSourceOptions options = camera;
  if (uri.rfind("camera:", 0) == 0) {
    options.device = uri.substr(7);
    return OpenCamera(options);
  }
  if (uri.rfind("/dev/video", 0) == 0) {
    options.device = uri;
    return OpenCamera(options);
  }
  if (fs::is_directory(uri)) return OpenImageFolder(uri, camera.fps, camera.width, camera.height);
  if (fs::is_regular_file(uri)) return OpenVideoFile(uri);
  if (fs::exists(uri)) {
    throw Error(fmt::format("frame source '{}' is neither a file nor a folder (a camera is camera:N or "
                            "/dev/videoN)", uri));
  }
  throw Error(fmt::format("frame source '{}': no such file or folder (a camera is camera:N or /dev/videoN)",
                          uri));
}

}  // namespace tac3d
