#include "tac3d/source/frame_source.h"

#include <algorithm>
#include <atomic>
#include <fstream>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "tac3d/imagefile/jpeg_decoder.h"
#include "tac3d/source/threaded_capture.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

cv::Mat Pattern(int value) {
  cv::Mat image(48, 64, CV_8UC1, cv::Scalar(value));
  image(cv::Rect(10, 10, 20, 20)) = 255 - value;
  return image;
}

TEST(ThreadedCapture, DeliversGreyFramesInOrder) {
  auto count = std::make_shared<std::atomic<int>>(0);
  ThreadedCapture capture(
      "test camera",
      [count](cv::Mat& image, std::string&) {
        image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(30, 60, 90));  // BGR
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        ++*count;
        return true;
      },
      5.0);
  Frame frame;
  std::int64_t last_index = -1;
  double last_t = -1;
  for (int k = 0; k < 5; ++k) {
    ASSERT_EQ(capture.Read(frame), ReadStatus::kOk) << capture.last_error();
    EXPECT_EQ(frame.image.type(), CV_8UC1);
    EXPECT_EQ(frame.image.size(), cv::Size(64, 48));
    EXPECT_EQ(frame.index, last_index + 1);
    EXPECT_GT(frame.timestamp_s, last_t);
    last_index = frame.index;
    last_t = frame.timestamp_s;
  }
  // Grey of BGR (30, 60, 90): 0.114 * 30 + 0.587 * 60 + 0.299 * 90 = 65.5.
  EXPECT_NEAR(frame.image.at<std::uint8_t>(0, 0), 65.5, 1.0);
}

TEST(ThreadedCapture, UnpluggedCameraFailsWithTheReasonAndStaysFailed) {
  auto frames = std::make_shared<std::atomic<int>>(0);
  ThreadedCapture capture(
      "test camera",
      [frames](cv::Mat& image, std::string& error) {
        if (++*frames > 3) {
          error = "the device is gone (unplugged)";
          return false;
        }
        image = Pattern(40);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        return true;
      },
      5.0);
  Frame frame;
  ReadStatus status = ReadStatus::kOk;
  int ok = 0;
  while ((status = capture.Read(frame)) == ReadStatus::kOk) ++ok;
  EXPECT_LE(ok, 3);
  EXPECT_EQ(status, ReadStatus::kFailed);
  EXPECT_THAT(capture.last_error(), HasSubstr("unplugged"));
  EXPECT_EQ(capture.Read(frame), ReadStatus::kFailed);
}

TEST(ThreadedCapture, StalledDriverTimesOutInsteadOfHanging) {
  auto release = std::make_shared<std::atomic<bool>>(false);
  {
    ThreadedCapture capture(
        "stalled camera",
        [release](cv::Mat&, std::string&) {
          while (!*release) std::this_thread::sleep_for(std::chrono::milliseconds(5));
          return false;
        },
        0.2);
    Frame frame;
    EXPECT_EQ(capture.Read(frame), ReadStatus::kFailed);
    EXPECT_THAT(capture.last_error(), HasSubstr("no frame within"));
    EXPECT_EQ(capture.Read(frame), ReadStatus::kFailed);
  }  // the destructor leaves the stuck thread behind
  *release = true;
}

// The MJPEG camera's path without a camera: the grab decodes each JPEG with the region the
// caller set last, and the frame says what was decoded; until a region is set, and after it is
// cleared, frames are decoded whole.
TEST(ThreadedCapture, ADecodingGrabDecodesTheRegionTheCallerSet) {
  std::vector<std::uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", Pattern(90), jpeg));
  auto decoder = std::make_shared<JpegGreyDecoder>();
  ThreadedCapture capture(
      "test MJPEG camera",
      ThreadedCapture::DecodingGrab([decoder, jpeg](const std::optional<cv::Rect>& region, cv::Mat& image,
                                                    std::optional<cv::Rect>& decoded, std::string& error) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        const JpegDecodeResult result = decoder->Decode(jpeg, 64, 48, region, image);
        error = result.refusal;
        decoded = region ? std::optional<cv::Rect>(result.decoded) : std::nullopt;
        return error.empty();
      }),
      5.0);
  Frame frame;
  ASSERT_EQ(capture.Read(frame), ReadStatus::kOk) << capture.last_error();
  EXPECT_FALSE(frame.decoded_region);
  EXPECT_NEAR(frame.image.at<std::uint8_t>(47, 63), 90, 2);
  const cv::Rect region(20, 5, 30, 20);
  capture.SetDecodeRegion(region);
  // A frame decoded before the region was set may still come first.
  for (int k = 0; k < 3 && capture.Read(frame) == ReadStatus::kOk && !frame.decoded_region; ++k) {
  }
  ASSERT_TRUE(frame.decoded_region);
  EXPECT_EQ(*frame.decoded_region, cv::Rect(16, 5, 34, 20));
  EXPECT_EQ(frame.image.at<std::uint8_t>(47, 63), 0);  // not decoded
  EXPECT_NEAR(frame.image.at<std::uint8_t>(15, 25), 255 - 90, 4);
  capture.SetDecodeRegion(std::nullopt);
  for (int k = 0; k < 3 && capture.Read(frame) == ReadStatus::kOk && frame.decoded_region; ++k) {
  }
  EXPECT_FALSE(frame.decoded_region);
  EXPECT_NEAR(frame.image.at<std::uint8_t>(47, 63), 90, 2);
}

TEST(ImageFolder, ReadsImagesInNameOrderAndFlagsACorruptOne) {
  const std::string dir = testing::MakeTempDir("image_folder");
  ASSERT_TRUE(cv::imwrite(dir + "/frame_000.png", Pattern(10)));
  ASSERT_TRUE(cv::imwrite(dir + "/frame_002.png", Pattern(30)));
  ASSERT_TRUE(cv::imwrite(dir + "/frame_003.jpg", Pattern(40)));
  std::ofstream(dir + "/frame_001.png") << "not a png";
  std::ofstream(dir + "/notes.txt") << "ignored";
  const auto source = OpenFrameSource(dir);
  EXPECT_THAT(source->Describe(), HasSubstr("4 images"));
  Frame frame;
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_EQ(frame.image.at<std::uint8_t>(0, 0), 10);
  EXPECT_EQ(frame.index, 0);
  ASSERT_EQ(source->Read(frame), ReadStatus::kBadFrame);
  EXPECT_THAT(source->last_error(), HasSubstr("frame_001.png"));
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_EQ(frame.image.at<std::uint8_t>(0, 0), 30);
  EXPECT_EQ(frame.index, 2);
  EXPECT_DOUBLE_EQ(frame.timestamp_s, 2.0 / 30.0);
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_NEAR(frame.image.at<std::uint8_t>(0, 0), 40, 3);  // JPEG
  EXPECT_EQ(source->Read(frame), ReadStatus::kEnd);
  EXPECT_EQ(source->Read(frame), ReadStatus::kEnd);
}

TEST(VideoFile, ReadsBackEveryFrameOfAnMjpegAvi) {
  const std::string path = testing::MakeTempDir("video_file") + "/clip.avi";
  {
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, cv::Size(64, 48),
                           /*isColor=*/false);
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 6; ++k) writer.write(Pattern(20 + 30 * k));
  }
  const auto source = OpenFrameSource(path);
  Frame frame;
  for (int k = 0; k < 6; ++k) {
    ASSERT_EQ(source->Read(frame), ReadStatus::kOk) << "frame " << k;
    EXPECT_EQ(frame.image.type(), CV_8UC1);
    EXPECT_EQ(frame.image.size(), cv::Size(64, 48));
    EXPECT_NEAR(frame.image.at<std::uint8_t>(2, 2), 20 + 30 * k, 4) << "frame " << k;
    EXPECT_EQ(frame.index, k);
  }
  EXPECT_EQ(source->Read(frame), ReadStatus::kEnd);
}

TEST(FrameSource, MissingThingsAreClearErrors) {
  CameraSourceOptions missing;
  missing.device = "/dev/video97";
  try {
    OpenCamera(missing);
    FAIL() << "opened a camera that does not exist";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/dev/video97: no such device"));
  }
  EXPECT_THROW(OpenFrameSource("camera:96"), Error);
  EXPECT_THROW(OpenFrameSource("/no/such/file.avi"), Error);
  const std::string dir = testing::MakeTempDir("empty_folder");
  EXPECT_THROW(OpenImageFolder(dir), Error);
  const std::string junk = dir + "/junk.avi";
  std::ofstream(junk) << "this is not a video";
  EXPECT_THROW(OpenVideoFile(junk), Error);
}

// Issue 14, defect 2: a 661-byte PNG claiming 60000 x 60000 pixels stopped the whole run
// (OpenCV threw on CV_IO_MAX_IMAGE_PIXELS). It is one bad frame; the next image is read.
TEST(ImageFolder, AnImageClaimingMorePixelsThanTheCameraIsOneBadFrame) {
  const std::string dir = testing::MakeTempDir("huge_header");
  ASSERT_TRUE(cv::imwrite(dir + "/frame_000.png", Pattern(10)));
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", Pattern(20), png));
  const std::uint8_t huge[4] = {0x00, 0x00, 0xEA, 0x60};  // 60000, big-endian
  std::copy(huge, huge + 4, png.begin() + 16);
  std::copy(huge, huge + 4, png.begin() + 20);
  std::ofstream(dir + "/frame_001.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()), png.size());
  ASSERT_TRUE(cv::imwrite(dir + "/frame_002.png", Pattern(30)));

  CameraSourceOptions camera;
  camera.width = 64;
  camera.height = 48;
  const auto source = OpenFrameSource(dir, camera);
  Frame frame;
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  ASSERT_EQ(source->Read(frame), ReadStatus::kBadFrame);
  EXPECT_THAT(source->last_error(), HasSubstr("frame_001.png': its header claims 60000 x 60000 pixels, more "
                                              "than the 64 x 48 accepted"));
  ASSERT_EQ(source->Read(frame), ReadStatus::kOk);
  EXPECT_EQ(frame.image.at<std::uint8_t>(2, 2), 30);
  EXPECT_EQ(source->Read(frame), ReadStatus::kEnd);
}

// Issue 14, defect 8: /dev/null was "does not exist"; a text file printed GStreamer's noise.
TEST(FrameSource, ADeviceOrATextFileIsRefusedWithItsReasonAndNoNoise) {
  try {
    OpenFrameSource("/dev/null");
    FAIL() << "opened /dev/null";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "frame source '/dev/null' is neither a file nor a folder (a camera is camera:N or /dev/videoN)");
  }
  const std::string text = testing::MakeTempDir("text_source") + "/notes.txt";
  std::ofstream(text) << "these are notes, not a video\n";
  ::testing::internal::CaptureStderr();
  try {
    OpenFrameSource(text);
    FAIL() << "opened a text file as a video";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("not a video FFmpeg or the MJPEG reader can read"));
  }
  const std::string noise = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(std::count(noise.begin(), noise.end(), '\n'), 0) << noise;
}

TEST(CameraSourceOptions, ValidateNamesTheField) {
  CameraSourceOptions options;
  EXPECT_NO_THROW(options.Validate());
  options.fps = 0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.width = 4;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.exposure = -1.0;
  EXPECT_THROW(options.Validate(), Error);
  options = {};
  options.pixel_format = "MJPG";
  EXPECT_NO_THROW(options.Validate());
  for (const char* bad : {"MJPEG", "YUY", "MJ G"}) {
    options.pixel_format = bad;
    EXPECT_THAT([&] { options.Validate(); },
                ThrowsMessage<Error>(HasSubstr(fmt::format("pixel format '{}' is not a V4L2 four-character code", bad))));
  }
}

// Issue 22, defect 11: `run --fps 1e300` was accepted for an image folder (every timestamp 0).
TEST(FrameSource, AnImageFolderRefusesAFrameRateNoCameraHas) {
  const std::string dir = testing::MakeTempDir("fps_folder");
  ASSERT_TRUE(cv::imwrite(dir + "/a.png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(0))));
  EXPECT_NO_THROW(OpenImageFolder(dir, 1000.0));
  EXPECT_THAT([&] { OpenImageFolder(dir, 1e300); },
              ::testing::ThrowsMessage<Error>(
                  HasSubstr("image folder: fps = 1e+300 must be in (0, 1000]")));
}

}  // namespace
}  // namespace tac3d
