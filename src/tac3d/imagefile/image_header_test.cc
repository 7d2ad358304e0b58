#include "tac3d/imagefile/image_header.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tac3d/imagefile/test_images.h"

namespace tac3d {
namespace {

using testing::EncodeUniformImage;

class ImageHeaderFormat : public ::testing::TestWithParam<const char*> {};

TEST_P(ImageHeaderFormat, ReadsTheSizeOfAnEncodedImage) {
  const std::vector<std::uint8_t> bytes = EncodeUniformImage(GetParam(), 37, 21);
  const auto dims = ReadImageHeaderDimensions(bytes.data(), bytes.size());
  ASSERT_TRUE(dims.has_value());
  EXPECT_EQ(dims->width, 37);
  EXPECT_EQ(dims->height, 21);
}

INSTANTIATE_TEST_SUITE_P(Formats,
                         ImageHeaderFormat,
                         ::testing::Values(".png", ".jpg", ".bmp", ".tiff", ".pgm"));

// A hostile file: a small PNG whose header claims 60000 x 60000 pixels.
TEST(ImageHeader, ReadsTheClaimOfAForgedPngWithoutDecodingIt) {
  std::vector<std::uint8_t> bytes = EncodeUniformImage(".png", 8, 8);
  const std::uint8_t huge[4] = {0x00, 0x00, 0xEA, 0x60};  // 60000, big-endian
  std::copy(huge, huge + 4, bytes.begin() + 16);
  std::copy(huge, huge + 4, bytes.begin() + 20);
  const auto dims = ReadImageHeaderDimensions(bytes.data(), bytes.size());
  ASSERT_TRUE(dims.has_value());
  EXPECT_EQ(dims->width, 60000);
  EXPECT_EQ(dims->height, 60000);
}

TEST(ImageHeader, UnknownOrShortDataHasNoSize) {
  const std::string text = "not an image at all";
  EXPECT_FALSE(
      ReadImageHeaderDimensions(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  const std::vector<std::uint8_t> png = EncodeUniformImage(".png", 8, 8);
  EXPECT_FALSE(ReadImageHeaderDimensions(png.data(), 12));
  const std::vector<std::uint8_t> jpeg = EncodeUniformImage(".jpg", 8, 8);
  EXPECT_FALSE(ReadImageHeaderDimensions(jpeg.data(), 6));
  EXPECT_FALSE(ReadImageHeaderDimensions(nullptr, 0));
}

}  // namespace
}  // namespace tac3d
