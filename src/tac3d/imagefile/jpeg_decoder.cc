#include "tac3d/imagefile/jpeg_decoder.h"

#include <csetjmp>
#include <cstdio>  // jpeglib.h needs FILE and size_t declared before it
#include <cstring>

#include <jpeglib.h>

#include <fmt/format.h>

#include "tac3d/imagefile/image_decode.h"

namespace tac3d {
namespace internal {

// libjpeg reports a fatal error by calling error_exit, which must not return: it jumps back to
// the setjmp of the call in progress. Between the setjmp and the jump only C data lives (no
// destructor is skipped), and the message is kept for the refusal. Not in the anonymous
// namespace: JpegGreyDecoder::Impl holds one.
struct JpegErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

}  // namespace internal

namespace {

void ExitWithError(j_common_ptr cinfo) {
  auto* err = reinterpret_cast<internal::JpegErrorManager*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, err->message);
  std::longjmp(err->jump, 1);
}

// A warning (corrupt data libjpeg decodes past) is not printed on stderr: a refusal says what
// matters, and a camera's stream would repeat it every frame.
void IgnoreMessage(j_common_ptr) {}

// The rows and columns to decode, in pixels of the image.
struct Span {
  int row_begin, row_end, col_begin, col_width;
};

}  // namespace

struct JpegGreyDecoder::Impl {
  jpeg_decompress_struct cinfo;
  internal::JpegErrorManager err;

  Impl() {
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = ExitWithError;
    err.pub.output_message = IgnoreMessage;
    jpeg_create_decompress(&cinfo);
  }
  ~Impl() { jpeg_destroy_decompress(&cinfo); }

  // Reads the header and asks for grey output: false (the message in err) if libjpeg refuses.
  bool ReadHeader(const std::uint8_t* data, std::size_t size) {
    if (setjmp(err.jump)) {
      jpeg_abort_decompress(&cinfo);
      return false;
    }
    jpeg_mem_src(&cinfo, data, static_cast<unsigned long>(size));
    jpeg_read_header(&cinfo, TRUE);
    cinfo.out_color_space = JCS_GRAYSCALE;
    return true;
  }

  // Decodes `span` into the rows of `pixels` (the image's first row, `step` bytes apart), its
  // column start moved left to a block column; false (the message in err) if libjpeg refuses.
  bool DecodeRows(Span& span, std::uint8_t* pixels, std::size_t step) {
    if (setjmp(err.jump)) {
      jpeg_abort_decompress(&cinfo);
      return false;
    }
    jpeg_start_decompress(&cinfo);
    auto col_begin = static_cast<JDIMENSION>(span.col_begin), col_width = static_cast<JDIMENSION>(span.col_width);
    if (col_width < cinfo.output_width) jpeg_crop_scanline(&cinfo, &col_begin, &col_width);
    span.col_begin = static_cast<int>(col_begin);
    span.col_width = static_cast<int>(col_width);
    if (span.row_begin > 0) jpeg_skip_scanlines(&cinfo, static_cast<JDIMENSION>(span.row_begin));
    while (static_cast<int>(cinfo.output_scanline) < span.row_end) {
      JSAMPROW row = pixels + cinfo.output_scanline * step + span.col_begin;
      jpeg_read_scanlines(&cinfo, &row, 1);
    }
    // The rows below are not needed: the rest of the data is not read.
    jpeg_abort_decompress(&cinfo);
    return true;
  }
};

JpegGreyDecoder::JpegGreyDecoder() : impl_(std::make_unique<Impl>()) {}
JpegGreyDecoder::~JpegGreyDecoder() = default;

JpegDecodeResult JpegGreyDecoder::Decode(const std::vector<std::uint8_t>& bytes, int max_width, int max_height,
                                         const std::optional<cv::Rect>& region, cv::Mat& image) {
  JpegDecodeResult result;
  result.refusal = internal::RefusalBeforeDecoding(bytes, max_width, max_height);
  if (!result.refusal.empty()) return result;
  const auto refuse = [&] {
    result.refusal = fmt::format("{}: {}", internal::kUnreadableImage, impl_->err.message);
    return result;
  };
  if (!impl_->ReadHeader(bytes.data(), bytes.size())) return refuse();
  const int width = static_cast<int>(impl_->cinfo.image_width), height = static_cast<int>(impl_->cinfo.image_height);
  if (width > max_width || height > max_height) {
    jpeg_abort_decompress(&impl_->cinfo);
    result.refusal = fmt::format("its header claims {} x {} pixels, more than the {} x {} accepted", width, height,
                                 max_width, max_height);
    return result;
  }
  image.create(height, width, CV_8UC1);
  const cv::Rect whole(0, 0, width, height);
  const cv::Rect wanted = region ? *region & whole : whole;
  if (wanted.empty()) {
    jpeg_abort_decompress(&impl_->cinfo);
    image.setTo(0);
    return result;
  }
  Span span{wanted.y, wanted.br().y, wanted.x, wanted.width};
  if (!impl_->DecodeRows(span, image.data, image.step)) return refuse();
  result.decoded = cv::Rect(span.col_begin, span.row_begin, span.col_width, span.row_end - span.row_begin);
  // What was not decoded is 0, not the last frame's pixels.
  image.rowRange(0, result.decoded.y).setTo(0);
  image.rowRange(result.decoded.br().y, height).setTo(0);
  if (result.decoded.width < width) {
    for (int r = result.decoded.y; r < result.decoded.br().y; ++r) {
      std::uint8_t* row = image.ptr(r);
      std::memset(row, 0, static_cast<std::size_t>(result.decoded.x));
      std::memset(row + result.decoded.br().x, 0, static_cast<std::size_t>(width - result.decoded.br().x));
    }
  }
  return result;
}

}  // namespace tac3d
