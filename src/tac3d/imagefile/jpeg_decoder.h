#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace tac3d {

/// What JpegGreyDecoder::Decode did.
struct JpegDecodeResult {
  std::string refusal;  ///< why the bytes were refused (as DecodeGrayImage says it); empty when decoded
  /// The part of the image decoded: the whole image, or the region asked for with its left edge
  /// moved left to a block column (a multiple of 8 px; up to 32 for the JPEGs libjpeg decodes, which
  /// may also decode the whole image). Empty when refused.
  cv::Rect decoded;
};

/// Decodes a camera's MJPEG frames (JPEG images) to 8-bit grey, the luma alone (a YCbCr JPEG's
/// colour is not decoded), whole or only where the caller will read them. Baseline JPEGs (every
/// camera's MJPEG, with or without their Huffman tables, any chroma subsampling, restart markers
/// or not) go through tac3d's own decoder (internal::JpegLumaDecoder): the compressed data is
/// read down to the region's last row and no further, coefficients are kept and transformed only
/// for the region's 8 x 8 blocks, and with restart markers the intervals above the region are
/// skipped unread. Its inverse DCT is the exact one in single precision, so its pixels are within
/// one grey level of libjpeg's (whose integer transform JPEG allows that error), a few percent of
/// them differing. Other JPEGs (progressive, arithmetic-coded, 12-bit, RGB) are decoded by
/// libjpeg-turbo, cropping and skipping rows as it can (whole when the luma is sampled less than
/// the colour planes). Either way a partial decode's pixels equal the whole decode's inside the
/// decoded rectangle. One decompressor, kept from frame to
/// frame; not thread-safe.
class JpegGreyDecoder {
 public:
  JpegGreyDecoder();
  ~JpegGreyDecoder();
  JpegGreyDecoder(const JpegGreyDecoder&) = delete;
  JpegGreyDecoder& operator=(const JpegGreyDecoder&) = delete;

  /// Decodes `bytes` into `image` (CV_8UC1 of the JPEG's size; its storage reused when it fits).
  /// Refused, never thrown, as DecodeGrayImage refuses: no bytes, a JPEG cut short, a header
  /// claiming more than max_width x max_height pixels (checked before decoding), or data that
  /// does not decode (a code no table holds, data ending before the rows asked for, a restart
  /// marker missing, what libjpeg refuses); `image` is then unspecified.
  /// @param region the pixels the caller will read (clipped to the image); nullopt: all of them.
  ///   Outside JpegDecodeResult::decoded the image is 0.
  JpegDecodeResult Decode(const std::vector<std::uint8_t>& bytes, int max_width, int max_height,
                          const std::optional<cv::Rect>& region, cv::Mat& image);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d
