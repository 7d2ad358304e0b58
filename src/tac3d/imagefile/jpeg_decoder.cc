#include "tac3d/imagefile/jpeg_decoder.h"

#include <algorithm>
#include <array>
#include <csetjmp>
#include <cstdio>  // jpeglib.h needs FILE and size_t declared before it
#include <cstring>

#include <jpeglib.h>

#include <fmt/format.h>

#include "tac3d/imagefile/image_decode.h"
#include "tac3d/imagefile/jpeg_luma_decoder.h"

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
  internal::JpegLumaDecoder luma;
  std::array<internal::JpegHuffmanSpec, 4> dc_specs, ac_specs;  // this frame's, for luma's scan

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

  // Whether the frame is a baseline JPEG in the layout JpegLumaDecoder takes, and if so its scan.
  // Motion-JPEG frames often leave out the Huffman tables, meaning JPEG's standard ones: libjpeg
  // installs them (for the frames after too) as it starts decompressing, which `started` then
  // says. False (the message in err) if libjpeg refuses.
  bool DescribeScan(internal::JpegScan& scan, bool& takes, bool& started) {
    takes = started = false;
    if (cinfo.progressive_mode || cinfo.arith_code || cinfo.data_precision != 8) return true;
    const bool grey = cinfo.jpeg_color_space == JCS_GRAYSCALE && cinfo.num_components == 1;
    const bool ycc = cinfo.jpeg_color_space == JCS_YCbCr && cinfo.num_components == 3;
    if (!(grey || ycc) || cinfo.comps_in_scan != cinfo.num_components) return true;
    if (cinfo.Ss != 0 || cinfo.Se != DCTSIZE2 - 1 || cinfo.Ah != 0 || cinfo.Al != 0) return true;
    // Table numbers past the slots are refused by libjpeg as it decodes, not as it reads the header.
    for (int i = 0; i < cinfo.comps_in_scan; ++i) {
      const jpeg_component_info& c = *cinfo.cur_comp_info[i];
      if (c.dc_tbl_no < 0 || c.dc_tbl_no >= NUM_HUFF_TBLS || c.ac_tbl_no < 0 || c.ac_tbl_no >= NUM_HUFF_TBLS) return true;
    }
    const int quant_slot = cinfo.comp_info[0].quant_tbl_no;
    if (quant_slot < 0 || quant_slot >= NUM_QUANT_TBLS || cinfo.quant_tbl_ptrs[quant_slot] == nullptr) return true;
    const JQUANT_TBL* quant = cinfo.quant_tbl_ptrs[quant_slot];
    const auto tables_missing = [&] {
      for (int i = 0; i < cinfo.comps_in_scan; ++i) {
        const jpeg_component_info& c = *cinfo.cur_comp_info[i];
        if (!cinfo.dc_huff_tbl_ptrs[c.dc_tbl_no] || !cinfo.ac_huff_tbl_ptrs[c.ac_tbl_no]) return true;
      }
      return false;
    };
    if (tables_missing()) {
      if (setjmp(err.jump)) {
        jpeg_abort_decompress(&cinfo);
        return false;
      }
      jpeg_start_decompress(&cinfo);
      started = true;
      if (tables_missing()) {
        jpeg_abort_decompress(&cinfo);
        std::snprintf(err.message, sizeof(err.message), "a Huffman table its scan uses is not defined");
        return false;
      }
    }
    scan = {};
    scan.width = static_cast<int>(cinfo.image_width);
    scan.height = static_cast<int>(cinfo.image_height);
    for (int i = 0; i < cinfo.comps_in_scan; ++i) {
      const jpeg_component_info& c = *cinfo.cur_comp_info[i];
      scan.components.push_back({c.h_samp_factor, c.v_samp_factor, &c == &cinfo.comp_info[0], c.dc_tbl_no, c.ac_tbl_no});
    }
    for (std::size_t t = 0; t < 4; ++t) {
      const auto copy = [](const JHUFF_TBL* table, internal::JpegHuffmanSpec& spec) -> const internal::JpegHuffmanSpec* {
        if (table == nullptr) return nullptr;
        std::memcpy(spec.counts.data(), table->bits, spec.counts.size());
        std::memcpy(spec.symbols.data(), table->huffval, spec.symbols.size());
        return &spec;
      };
      scan.dc[t] = copy(cinfo.dc_huff_tbl_ptrs[t], dc_specs[t]);
      scan.ac[t] = copy(cinfo.ac_huff_tbl_ptrs[t], ac_specs[t]);
    }
    std::copy(std::begin(quant->quantval), std::end(quant->quantval), scan.luma_quant.begin());
    scan.restart_interval = static_cast<int>(cinfo.restart_interval);
    scan.data = cinfo.src->next_input_byte;
    scan.size = cinfo.src->bytes_in_buffer;
    takes = internal::JpegLumaDecoder::Takes(scan);
    return true;
  }

  // Decodes `span` into the rows of `pixels` (the image's first row, `step` bytes apart) with
  // libjpeg, its column start moved left to a block column; false (the message in err) if
  // libjpeg refuses.
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

  // Decodes `span` of the JPEG `data` (its header read) as DecodeRows does, with JpegLumaDecoder
  // where it takes the frame; "" or why the frame does not decode.
  std::string Decode(const std::uint8_t* data, std::size_t size, Span& span, std::uint8_t* pixels,
                     std::size_t step) {
    internal::JpegScan scan;
    bool takes = false, started = false;
    if (!DescribeScan(scan, takes, started)) return err.message;
    if (!takes) {
      // libjpeg decodes it, from its header again if DescribeScan started decompressing.
      if (started) {
        jpeg_abort_decompress(&cinfo);
        if (!ReadHeader(data, size)) return err.message;
      }
      // A luma sampled less than the colour planes is upsampled, which libjpeg does differently
      // at a cropped or skipped edge: such a frame is decoded whole.
      const jpeg_component_info& luma_info = cinfo.comp_info[0];
      if (luma_info.h_samp_factor != cinfo.max_h_samp_factor || luma_info.v_samp_factor != cinfo.max_v_samp_factor) {
        span = {0, static_cast<int>(cinfo.image_height), 0, static_cast<int>(cinfo.image_width)};
      }
      return DecodeRows(span, pixels, step) ? "" : err.message;
    }
    const int col_end = span.col_begin + span.col_width;
    span.col_begin -= span.col_begin % DCTSIZE;
    span.col_width = col_end - span.col_begin;
    const std::string error = luma.Decode(scan, {span.row_begin, span.row_end, span.col_begin, col_end}, pixels, step);
    jpeg_abort_decompress(&cinfo);
    return error;
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
  if (const std::string error = impl_->Decode(bytes.data(), bytes.size(), span, image.data, image.step);
      !error.empty()) {
    result.refusal = fmt::format("{}: {}", internal::kUnreadableImage, error);
    return result;
  }
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
