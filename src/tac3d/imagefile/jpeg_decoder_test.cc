#include "tac3d/imagefile/jpeg_decoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "tac3d/imagefile/image_decode.h"
#include "tac3d/imagefile/test_images.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

// A camera-like frame: dark dots on a lit, noisy film, so every block has detail to decode.
cv::Mat DotsFrame(int width, int height) {
  cv::Mat grey(height, width, CV_8UC1, cv::Scalar(190));
  for (int y = 20; y < height; y += 37) {
    for (int x = 15; x < width; x += 41) cv::circle(grey, {x, y}, 9, cv::Scalar(40), cv::FILLED, cv::LINE_AA);
  }
  cv::Mat noise(grey.size(), CV_8UC1);
  cv::theRNG().state = testing::kRandomSeed;
  cv::randn(noise, 0, 3);
  cv::add(grey, noise, grey);
  return grey;
}

// As an MJPEG camera sends it: colour (YCbCr 4:2:0), or grey.
std::vector<std::uint8_t> Encode(const cv::Mat& grey, bool colour) {
  cv::Mat image = grey;
  if (colour) cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
  std::vector<std::uint8_t> jpeg;
  EXPECT_TRUE(cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90}));
  return jpeg;
}

TEST(JpegGreyDecoder, AWholeDecodeIsOpenCvsGreyDecodeToTheLastBit) {
  JpegGreyDecoder decoder;
  for (bool colour : {true, false}) {
    const std::vector<std::uint8_t> jpeg = Encode(DotsFrame(640, 480), colour);
    cv::Mat image;
    const JpegDecodeResult result = decoder.Decode(jpeg, 640, 480, std::nullopt, image);
    EXPECT_EQ(result.refusal, "");
    EXPECT_EQ(result.decoded, cv::Rect(0, 0, 640, 480));
    ASSERT_EQ(image.type(), CV_8UC1);
    const cv::Mat expected = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    EXPECT_EQ(cv::norm(image, expected, cv::NORM_INF), 0) << "colour " << colour;
  }
}

TEST(JpegGreyDecoder, APartialDecodeEqualsTheWholeInsideItsRectangleAndIsZeroOutside) {
  JpegGreyDecoder decoder;
  for (bool colour : {true, false}) {
    const std::vector<std::uint8_t> jpeg = Encode(DotsFrame(640, 480), colour);
    cv::Mat whole;
    ASSERT_EQ(decoder.Decode(jpeg, 640, 480, std::nullopt, whole).refusal, "");
    // The whole decode's pixels are in `image` before each partial one: none may stay outside.
    cv::Mat image = whole.clone();
    for (const cv::Rect& region : {cv::Rect(37, 53, 300, 200), cv::Rect(0, 0, 17, 9), cv::Rect(600, 470, 40, 10),
                                   cv::Rect(129, 1, 1, 478)}) {
      const JpegDecodeResult result = decoder.Decode(jpeg, 640, 480, region, image);
      ASSERT_EQ(result.refusal, "");
      const cv::Rect& decoded = result.decoded;
      // The rows asked for; the columns from the block column at or left of the region's.
      EXPECT_EQ(decoded.y, region.y);
      EXPECT_EQ(decoded.height, region.height);
      EXPECT_EQ(decoded.br().x, region.br().x) << region;
      EXPECT_LE(decoded.x, region.x);
      EXPECT_GT(decoded.x, region.x - (colour ? 16 : 8)) << region;
      EXPECT_EQ(decoded.x % 8, 0);
      EXPECT_EQ(cv::norm(image(decoded), whole(decoded), cv::NORM_INF), 0) << region;
      cv::Mat outside = image.clone();
      outside(decoded).setTo(0);
      EXPECT_EQ(cv::countNonZero(outside), 0) << region;
    }
  }
}

TEST(JpegGreyDecoder, ARegionIsClippedToTheImage) {
  JpegGreyDecoder decoder;
  const std::vector<std::uint8_t> jpeg = Encode(DotsFrame(320, 240), true);
  cv::Mat image;
  EXPECT_EQ(decoder.Decode(jpeg, 320, 240, cv::Rect(300, -20, 100, 50), image).decoded, cv::Rect(288, 0, 32, 30));
  const JpegDecodeResult missed = decoder.Decode(jpeg, 320, 240, cv::Rect(400, 0, 10, 10), image);
  EXPECT_EQ(missed.refusal, "");
  EXPECT_TRUE(missed.decoded.empty());
  ASSERT_EQ(image.size(), cv::Size(320, 240));
  EXPECT_EQ(cv::countNonZero(image), 0);
}

TEST(JpegGreyDecoder, RefusesAsDecodeGrayImageDoes) {
  JpegGreyDecoder decoder;
  cv::Mat image;
  EXPECT_THAT(decoder.Decode({}, 64, 64, std::nullopt, image).refusal, HasSubstr("empty"));
  std::vector<std::uint8_t> jpeg = testing::EncodeUniformImage(".jpg", 32, 32);
  EXPECT_THAT(decoder.Decode(jpeg, 31, 32, std::nullopt, image).refusal,
              HasSubstr("header claims 32 x 32 pixels, more than the 31 x 32 accepted"));
  std::vector<std::uint8_t> truncated(jpeg.begin(), jpeg.end() - 10);
  EXPECT_THAT(decoder.Decode(truncated, 64, 64, std::nullopt, image).refusal, HasSubstr("truncated JPEG"));
  const std::string text = "not an image at all";
  const JpegDecodeResult refused =
      decoder.Decode(std::vector<std::uint8_t>(text.begin(), text.end()), 64, 64, std::nullopt, image);
  EXPECT_THAT(refused.refusal, HasSubstr("not a readable image"));
  EXPECT_TRUE(refused.decoded.empty());
  // A PNG is not a JPEG: libjpeg's own message says so.
  EXPECT_THAT(decoder.Decode(testing::EncodeUniformImage(".png", 8, 8), 64, 64, std::nullopt, image).refusal,
              HasSubstr("Not a JPEG file"));
  // The decoder is whole again after a refusal.
  const JpegDecodeResult good = decoder.Decode(jpeg, 64, 64, std::nullopt, image);
  EXPECT_EQ(good.refusal, "");
  EXPECT_EQ(image.at<std::uint8_t>(5, 5), testing::kUniformGrey);
}

// Bytes changed anywhere, whole or partial decodes: a frame or a refusal, never a crash; and each
// refusal leaves the decoder able to decode the next frame.
TEST(JpegGreyDecoder, CorruptFramesAreDecodedOrRefusedAndTheNextOneDecodes) {
  JpegGreyDecoder decoder;
  const std::vector<std::uint8_t> jpeg = Encode(DotsFrame(160, 120), true);
  std::mt19937 rng(testing::kRandomSeed);
  int refused = 0;
  cv::Mat image;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<std::uint8_t> bytes = jpeg;
    const std::size_t span = trial % 2 == 0 ? std::min<std::size_t>(bytes.size(), 700) : bytes.size();
    for (int e = 0; e < 1 + trial % 4; ++e) {
      bytes[std::uniform_int_distribution<std::size_t>(0, span - 1)(rng)] =
          static_cast<std::uint8_t>(std::uniform_int_distribution<int>(0, 255)(rng));
    }
    const std::optional<cv::Rect> region =
        trial % 3 == 0 ? std::nullopt : std::optional<cv::Rect>(cv::Rect(30, 20, 90, 70));
    const JpegDecodeResult result = decoder.Decode(bytes, 4096, 4096, region, image);
    refused += !result.refusal.empty();
    if (result.refusal.empty()) {
      EXPECT_EQ(image.type(), CV_8UC1);
    }
    ASSERT_EQ(decoder.Decode(jpeg, 160, 120, std::nullopt, image).refusal, "") << "after trial " << trial;
  }
  EXPECT_GT(refused, 0);  // the header's edits do refuse some
}

}  // namespace
}  // namespace tac3d
