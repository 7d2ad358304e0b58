#include "tac3d/imagefile/image_decode.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tac3d/imagefile/test_images.h"

namespace tac3d {
namespace {

using testing::EncodeUniformImage;
using testing::kUniformGrey;

using ::testing::HasSubstr;

TEST(DecodeGrayImage, DecodesAnImageWithinTheLimit) {
  const DecodedImage decoded = DecodeGrayImage(EncodeUniformImage(".png", 40, 30), 40, 30);
  EXPECT_EQ(decoded.refusal, "");
  ASSERT_EQ(decoded.image.size(), cv::Size(40, 30));
  EXPECT_EQ(decoded.image.type(), CV_8UC1);
  EXPECT_EQ(decoded.image.at<std::uint8_t>(10, 10), kUniformGrey);
}

TEST(DecodeGrayImage, RefusesAHeaderClaimingMoreThanTheLimitBeforeDecoding) {
  std::vector<std::uint8_t> bytes = EncodeUniformImage(".png", 8, 8);
  const std::uint8_t huge[4] = {0x00, 0x00, 0xEA, 0x60};  // 60000, big-endian
  std::copy(huge, huge + 4, bytes.begin() + 16);
  std::copy(huge, huge + 4, bytes.begin() + 20);
  const DecodedImage decoded = DecodeGrayImage(bytes, kMaxImageSidePx, kMaxImageSidePx);
  EXPECT_TRUE(decoded.image.empty());
  EXPECT_THAT(decoded.refusal, HasSubstr("header claims 60000 x 60000 pixels, more than the 8192 x 8192"));
  EXPECT_THAT(DecodeGrayImage(EncodeUniformImage(".png", 41, 30), 40, 30).refusal,
              HasSubstr("41 x 30"));
}

TEST(DecodeGrayImage, RefusesEmptyTruncatedAndCorruptFiles) {
  EXPECT_THAT(DecodeGrayImage({}, 64, 64).refusal, HasSubstr("empty"));
  std::vector<std::uint8_t> jpeg = EncodeUniformImage(".jpg", 32, 32);
  jpeg.resize(jpeg.size() - 10);
  EXPECT_THAT(DecodeGrayImage(jpeg, 64, 64).refusal, HasSubstr("truncated JPEG"));
  const std::string text = "not an image at all";
  const DecodedImage corrupt = DecodeGrayImage(std::vector<std::uint8_t>(text.begin(), text.end()), 64, 64);
  EXPECT_TRUE(corrupt.image.empty());
  EXPECT_THAT(corrupt.refusal, HasSubstr("not a readable image"));
}

}  // namespace
}  // namespace tac3d
