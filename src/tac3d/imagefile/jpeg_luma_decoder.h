#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tac3d {
namespace internal {

/// A Huffman table as a JPEG's DHT segment gives it.
struct JpegHuffmanSpec {
  std::array<std::uint8_t, 17> counts{};  ///< counts[l]: the number of codes of length l (1..16); counts[0] unused
  std::array<std::uint8_t, 256> symbols{};  ///< the symbols, shortest codes first
  bool operator==(const JpegHuffmanSpec&) const = default;
};

/// One component of a scan, in the scan's order.
struct JpegScanComponent {
  int h = 1, v = 1;  ///< sampling factors: blocks across and down in an MCU
  bool luma = false;  ///< the component decoded (the first of the frame: Y, or the only one)
  int dc_table = 0, ac_table = 0;  ///< indexes into JpegScan::dc / ac
};

/// What the luma decoder needs of a baseline sequential Huffman JPEG (one scan holding every
/// component), as libjpeg's header reader parsed it.
struct JpegScan {
  int width = 0, height = 0;
  std::vector<JpegScanComponent> components;
  std::array<const JpegHuffmanSpec*, 4> dc{}, ac{};  ///< the tables by slot; nullptr: not defined
  std::array<std::uint16_t, 64> luma_quant{};  ///< the luma's quantisation table, natural (row-major) order
  int restart_interval = 0;  ///< MCUs between restart markers; 0: none
  const std::uint8_t* data = nullptr;  ///< the entropy-coded data, from just after the SOS segment
  std::size_t size = 0;  ///< bytes from `data` to the end of the file
};

/// The pixels to decode: rows [row_begin, row_end), columns [col_begin, col_end) of the image.
struct JpegPixelSpan {
  int row_begin = 0, row_end = 0, col_begin = 0, col_end = 0;
};

/// Decodes the luma of a baseline JPEG's scan, only where asked, faster than libjpeg does it for
/// a partial decode: the entropy-coded data is read up to the last MCU row asked for and no
/// further; coefficients are kept only for the luma blocks that hold asked-for pixels; with
/// restart markers, intervals holding none of them are skipped unread. The inverse DCT is the
/// exact separable one in single precision (libjpeg's integer one is within one grey level of it,
/// as JPEG's accuracy bound asks), so pixels may differ from libjpeg's by one grey level.
/// Tables built from a file's Huffman specs are kept while the next frames bring the same ones
/// (a camera's stream). Not thread-safe.
class JpegLumaDecoder {
 public:
  JpegLumaDecoder();
  ~JpegLumaDecoder();
  JpegLumaDecoder(const JpegLumaDecoder&) = delete;
  JpegLumaDecoder& operator=(const JpegLumaDecoder&) = delete;

  /// Whether Decode takes this scan's layout (else decode it with libjpeg): every component
  /// in the scan, the luma at the highest sampling, at most 10 blocks an MCU, and its tables
  /// defined.
  static bool Takes(const JpegScan& scan);

  /// Decodes `span` (inside the image; columns from a multiple of 8) of the luma into `pixels`
  /// (the image's first row, `step` bytes between rows). Pixels outside the span are not written.
  /// @pre Takes(scan)
  /// @return "" when decoded, else why the data cannot be (a Huffman table that is not one, a
  ///   code no table holds, coefficients past the block's end, data ending before the span does,
  ///   a restart marker missing).
  std::string Decode(const JpegScan& scan, const JpegPixelSpan& span, std::uint8_t* pixels, std::size_t step);

  struct Tables;  ///< a Huffman table's decoding tables (in the .cc)

 private:
  std::vector<Tables> tables_;  // built tables by spec, a few at most
  const Tables& TablesFor(const JpegHuffmanSpec& spec, bool ac, std::string& error);
};

}  // namespace internal
}  // namespace tac3d
