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
  /// moved left to a JPEG block column (libjpeg crops at 8 or 16 px steps). Empty when refused.
  cv::Rect decoded;
};

/// Decodes a camera's MJPEG frames (JPEG images) to 8-bit grey, the luma alone (a YCbCr JPEG's
/// colour is not decoded), whole or only where the caller will read them: libjpeg-turbo's
/// partial decoding, which still reads all of the compressed data above the region (a JPEG's
/// rows cannot be skipped without decoding them, short of restart markers) but transforms only
/// the region's 8 x 8 blocks (the inverse DCT) and stops after its last row. Inside the decoded
/// rectangle the pixels equal a whole decode's, to the last bit. One decompressor, kept from frame
/// to frame; not thread-safe.
class JpegGreyDecoder {
 public:
  JpegGreyDecoder();
  ~JpegGreyDecoder();
  JpegGreyDecoder(const JpegGreyDecoder&) = delete;
  JpegGreyDecoder& operator=(const JpegGreyDecoder&) = delete;

  /// Decodes `bytes` into `image` (CV_8UC1 of the JPEG's size; its storage reused when it fits).
  /// Refused, never thrown, as DecodeGrayImage refuses: no bytes, a JPEG cut short, a header
  /// claiming more than max_width x max_height pixels (checked before decoding), or data libjpeg
  /// cannot decode; `image` is then unspecified.
  /// @param region the pixels the caller will read (clipped to the image); nullopt: all of them.
  ///   Outside JpegDecodeResult::decoded the image is 0.
  JpegDecodeResult Decode(const std::vector<std::uint8_t>& bytes, int max_width, int max_height,
                          const std::optional<cv::Rect>& region, cv::Mat& image);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tac3d
