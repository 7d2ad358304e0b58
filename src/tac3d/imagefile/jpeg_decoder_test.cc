#include "tac3d/imagefile/jpeg_decoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>  // jpeglib.h needs FILE and size_t declared before it
#include <jpeglib.h>
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

// The exact inverse DCT against libjpeg's integer one (OpenCV's decoder): JPEG's accuracy bound
// allows the integer one a grey level of error, so a few pixels differ by one, none by more.
// How EncodeWithLibjpeg lays a frame out, as cameras' MJPEG and files vary.
struct JpegLayout {
  bool colour = true;
  int luma_h = 2, luma_v = 2;  // the luma's sampling: 2 x 2 is 4:2:0, 2 x 1 is 4:2:2 (UVC cameras), 1 x 1 is 4:4:4
  int chroma_h = 1, chroma_v = 1;  // the colour planes' (more than the luma's: a JPEG libjpeg decodes)
  int restart_interval = 0;  // MCUs between restart markers
  bool optimised_tables = false;  // Huffman tables made for the frame, not JPEG's standard ones
  bool progressive = false;
};

std::vector<std::uint8_t> EncodeWithLibjpeg(const cv::Mat& grey, const JpegLayout& layout) {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr err;
  cinfo.err = jpeg_std_error(&err);
  jpeg_create_compress(&cinfo);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&cinfo, &buffer, &size);
  cv::Mat input = grey;
  if (layout.colour) cv::cvtColor(grey, input, cv::COLOR_GRAY2RGB);
  cinfo.image_width = static_cast<JDIMENSION>(input.cols);
  cinfo.image_height = static_cast<JDIMENSION>(input.rows);
  cinfo.input_components = input.channels();
  cinfo.in_color_space = layout.colour ? JCS_RGB : JCS_GRAYSCALE;
  jpeg_set_defaults(&cinfo);
  cinfo.comp_info[0].h_samp_factor = layout.luma_h;
  cinfo.comp_info[0].v_samp_factor = layout.luma_v;
  for (int c = 1; c < cinfo.num_components; ++c) {
    cinfo.comp_info[c].h_samp_factor = layout.chroma_h;
    cinfo.comp_info[c].v_samp_factor = layout.chroma_v;
  }
  jpeg_set_quality(&cinfo, 90, TRUE);
  cinfo.restart_interval = static_cast<unsigned>(layout.restart_interval);
  cinfo.optimize_coding = layout.optimised_tables;
  if (layout.progressive) jpeg_simple_progression(&cinfo);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = input.ptr(static_cast<int>(cinfo.next_scanline));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::vector<std::uint8_t> jpeg(buffer, buffer + size);
  std::free(buffer);
  return jpeg;
}

// The JPEG without its Huffman tables (DHT segments), as Motion-JPEG frames come when they use
// JPEG's standard ones.
std::vector<std::uint8_t> WithoutHuffmanTables(const std::vector<std::uint8_t>& jpeg) {
  std::vector<std::uint8_t> out(jpeg.begin(), jpeg.begin() + 2);
  std::size_t at = 2;
  while (at + 4 <= jpeg.size() && jpeg[at] == 0xFF && jpeg[at + 1] != 0xDA) {
    const std::size_t length = 2 + (static_cast<std::size_t>(jpeg[at + 2]) << 8 | jpeg[at + 3]);
    if (jpeg[at + 1] != 0xC4) out.insert(out.end(), jpeg.begin() + static_cast<long>(at), jpeg.begin() + static_cast<long>(at + length));
    at += length;
  }
  out.insert(out.end(), jpeg.begin() + static_cast<long>(at), jpeg.end());
  return out;
}

// Where the entropy-coded data starts: just past the SOS segment.
std::size_t ScanDataStart(const std::vector<std::uint8_t>& jpeg) {
  std::size_t at = 2;
  while (jpeg[at + 1] != 0xDA) at += 2 + (static_cast<std::size_t>(jpeg[at + 2]) << 8 | jpeg[at + 3]);
  return at + 2 + (static_cast<std::size_t>(jpeg[at + 2]) << 8 | jpeg[at + 3]);
}

// Every layout a camera or a file may use, odd sizes too: the whole decode within a grey level of
// OpenCV's, a partial one equal to the whole inside its rectangle, whatever the layout.
TEST(JpegGreyDecoder, EveryLayoutDecodesWithinOneGreyLevelOfOpenCvAndPartlyAsWhole) {
  JpegGreyDecoder decoder;
  const cv::Mat grey = DotsFrame(157, 93);
  const std::vector<JpegLayout> layouts = {
      {.colour = false, .luma_h = 1, .luma_v = 1}, {.luma_h = 2, .luma_v = 2}, {.luma_h = 2, .luma_v = 1},
      {.luma_h = 1, .luma_v = 1}, {.luma_h = 1, .luma_v = 2}, {.restart_interval = 1},
      {.restart_interval = 7}, {.colour = false, .restart_interval = 13}, {.optimised_tables = true},
      {.progressive = true}, {.luma_h = 1, .luma_v = 1, .chroma_h = 2, .chroma_v = 2}};
  for (size_t i = 0; i < layouts.size(); ++i) {
    const std::vector<std::uint8_t> jpeg = EncodeWithLibjpeg(grey, layouts[i]);
    cv::Mat whole, partial;
    ASSERT_EQ(decoder.Decode(jpeg, 157, 93, std::nullopt, whole).refusal, "") << "layout " << i;
    EXPECT_LE(cv::norm(whole, cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE), cv::NORM_INF), 1) << "layout " << i;
    for (const cv::Rect& region : {cv::Rect(37, 21, 100, 50), cv::Rect(150, 90, 7, 3), cv::Rect(0, 0, 9, 93)}) {
      const JpegDecodeResult result = decoder.Decode(jpeg, 157, 93, region, partial);
      ASSERT_EQ(result.refusal, "") << "layout " << i;
      EXPECT_EQ(cv::norm(partial(result.decoded), whole(result.decoded), cv::NORM_INF), 0)
          << "layout " << i << " " << region;
    }
  }
}

// A Motion-JPEG frame without Huffman tables means JPEG's standard ones: decoded as the same
// frame with them is, by tac3d's decoder (4:2:2, as UVC cameras send) or libjpeg (colour planes
// sampled more than the luma).
TEST(JpegGreyDecoder, AFrameWithoutHuffmanTablesUsesTheStandardOnes) {
  for (const JpegLayout& layout : {JpegLayout{.luma_h = 2, .luma_v = 1},
                                   JpegLayout{.luma_h = 1, .luma_v = 1, .chroma_h = 2, .chroma_v = 2}}) {
    const std::vector<std::uint8_t> jpeg = EncodeWithLibjpeg(DotsFrame(160, 120), layout);
    const std::vector<std::uint8_t> mjpeg = WithoutHuffmanTables(jpeg);
    ASSERT_LT(mjpeg.size(), jpeg.size() - 400);  // the four standard tables are gone
    JpegGreyDecoder decoder;
    cv::Mat with, without;
    ASSERT_EQ(decoder.Decode(jpeg, 160, 120, std::nullopt, with).refusal, "");
    // A fresh decoder: no table left over from an earlier frame.
    JpegGreyDecoder fresh;
    ASSERT_EQ(fresh.Decode(mjpeg, 160, 120, std::nullopt, without).refusal, "") << layout.chroma_h;
    EXPECT_EQ(cv::norm(with, without, cv::NORM_INF), 0) << layout.chroma_h;
    // And the next frame, partly.
    const JpegDecodeResult partial = fresh.Decode(mjpeg, 160, 120, cv::Rect(20, 30, 100, 50), without);
    ASSERT_EQ(partial.refusal, "") << layout.chroma_h;
    EXPECT_EQ(cv::norm(with(partial.decoded), without(partial.decoded), cv::NORM_INF), 0) << layout.chroma_h;
  }
}

// With restart markers, the intervals above the region are not decoded: damage there does not
// reach a partial decode, while a whole one meets it.
TEST(JpegGreyDecoder, WithRestartMarkersIntervalsAboveTheRegionAreSkippedUnread) {
  JpegGreyDecoder decoder;
  const int mcus_across = 640 / 16;
  const std::vector<std::uint8_t> jpeg =
      EncodeWithLibjpeg(DotsFrame(640, 480), {.luma_h = 2, .luma_v = 2, .restart_interval = mcus_across});
  cv::Mat whole, partial;
  ASSERT_EQ(decoder.Decode(jpeg, 640, 480, std::nullopt, whole).refusal, "");
  std::vector<std::uint8_t> damaged = jpeg;
  // Bytes of the first MCU row turned into a code no table holds (all ones), stuffed as JPEG stuffs 0xFF.
  const std::size_t start = ScanDataStart(jpeg) + 10;
  for (std::size_t k = 0; k < 8; k += 2) {
    damaged[start + k] = 0xFF;
    damaged[start + k + 1] = 0x00;
  }
  cv::Mat damaged_whole;
  EXPECT_THAT(decoder.Decode(damaged, 640, 480, std::nullopt, damaged_whole).refusal, HasSubstr("corrupt (MCU row 0)"));
  const cv::Rect region(100, 200, 300, 150);
  const JpegDecodeResult result = decoder.Decode(damaged, 640, 480, region, partial);
  ASSERT_EQ(result.refusal, "");
  EXPECT_EQ(cv::norm(partial(result.decoded), whole(result.decoded), cv::NORM_INF), 0);
}

// Data cut short before the rows asked for, or a restart marker missing: refused, saying which.
TEST(JpegGreyDecoder, DataEndingEarlyOrAMissingRestartMarkerIsRefused) {
  JpegGreyDecoder decoder;
  cv::Mat image;
  for (int interval : {0, 40}) {
    std::vector<std::uint8_t> jpeg =
        EncodeWithLibjpeg(DotsFrame(640, 480), {.luma_h = 2, .luma_v = 2, .restart_interval = interval});
    const std::size_t start = ScanDataStart(jpeg);
    // Half the data, then the end of the image.
    std::vector<std::uint8_t> cut(jpeg.begin(), jpeg.begin() + static_cast<long>(start + (jpeg.size() - start) / 2));
    cut.insert(cut.end(), {0xFF, 0xD9});
    EXPECT_THAT(decoder.Decode(cut, 640, 480, std::nullopt, image).refusal, HasSubstr("ends early"))
        << "interval " << interval;
    // The first half of the rows is all there.
    EXPECT_EQ(decoder.Decode(cut, 640, 480, cv::Rect(0, 0, 640, 160), image).refusal, "") << "interval " << interval;
  }
  std::vector<std::uint8_t> jpeg = EncodeWithLibjpeg(DotsFrame(640, 480), {.restart_interval = 40});
  // The third restart marker (RST2) renamed RST5.
  int seen = 0;
  for (std::size_t at = ScanDataStart(jpeg); at + 1 < jpeg.size(); ++at) {
    if (jpeg[at] == 0xFF && jpeg[at + 1] >= 0xD0 && jpeg[at + 1] <= 0xD7 && seen++ == 2) {
      jpeg[at + 1] = 0xD5;
      break;
    }
  }
  EXPECT_THAT(decoder.Decode(jpeg, 640, 480, std::nullopt, image).refusal, HasSubstr("restart marker 2 is missing"));
}

TEST(JpegGreyDecoder, AWholeDecodeIsWithinOneGreyLevelOfOpenCvsGreyDecode) {
  JpegGreyDecoder decoder;
  for (bool colour : {true, false}) {
    const std::vector<std::uint8_t> jpeg = Encode(DotsFrame(640, 480), colour);
    cv::Mat image;
    const JpegDecodeResult result = decoder.Decode(jpeg, 640, 480, std::nullopt, image);
    EXPECT_EQ(result.refusal, "");
    EXPECT_EQ(result.decoded, cv::Rect(0, 0, 640, 480));
    ASSERT_EQ(image.type(), CV_8UC1);
    const cv::Mat expected = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    EXPECT_EQ(cv::norm(image, expected, cv::NORM_INF), 1) << "colour " << colour;
    cv::Mat differ;
    cv::compare(image, expected, differ, cv::CMP_NE);
    const double share = cv::countNonZero(differ) / static_cast<double>(image.total());
    EXPECT_LT(share, 0.05) << "colour " << colour;
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
      EXPECT_GT(decoded.x, region.x - 8) << region;
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
  EXPECT_EQ(decoder.Decode(jpeg, 320, 240, cv::Rect(300, -20, 100, 50), image).decoded, cv::Rect(296, 0, 24, 30));
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
  const cv::Mat grey = DotsFrame(160, 120);
  // OpenCV's 4:2:0, with restart markers, grey, and progressive (libjpeg's own decoding).
  const std::vector<std::vector<std::uint8_t>> frames = {
      Encode(grey, true), EncodeWithLibjpeg(grey, {.restart_interval = 3}),
      EncodeWithLibjpeg(grey, {.colour = false, .luma_h = 1, .luma_v = 1, .restart_interval = 11}),
      EncodeWithLibjpeg(grey, {.progressive = true})};
  std::mt19937 rng(testing::kRandomSeed);
  int refused = 0;
  cv::Mat image;
  for (int trial = 0; trial < 1200; ++trial) {
    const std::vector<std::uint8_t>& jpeg = frames[static_cast<std::size_t>(trial) % frames.size()];
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
