#include "tac3d/imagefile/jpeg_luma_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include <fmt/format.h>

#include "tac3d/util/error.h"

namespace tac3d {
namespace internal {
namespace {

// The natural (row-major) index of the k-th coefficient of a block in the data's zigzag order.
constexpr std::array<std::uint8_t, 64> kNaturalOrder = {
    0,  1,  8,  16, 9,  2,  3,  10, 17, 24, 32, 25, 18, 11, 4,  5,  12, 19, 26, 33, 40, 48,
    41, 34, 27, 20, 13, 6,  7,  14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
    30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};

// Codes this short (and, in AC tables, a code with its value bits) are decoded by one table read.
constexpr int kLookupBits = 10;
// Flags an AC table's end-of-block code in its value lookup.
constexpr std::int32_t kEndOfBlock = 1 << 14;

// A value of `size` bits as JPEG codes it: the upper half of the range positive, the lower negative.
inline int Extend(int bits, int size) { return bits < (1 << (size - 1)) ? bits - (1 << size) + 1 : bits; }

// The entropy-coded data as bits, most significant first, with its stuffed zero bytes removed.
// Past the data (a marker, or the end of the bytes) zeros are fed and counted, so a decode that
// ran into them is told from one that did not.
class BitReader {
 public:
  BitReader(const std::uint8_t* data, std::size_t size) : p_(data), end_(data + size) {}

  // At least 57 bits buffered after this (zeros past the data).
  void Refill() {
    if (end_ - p_ >= 8) {
      std::uint64_t word;
      std::memcpy(&word, p_, 8);
      word = __builtin_bswap64(word);
      // Eight bytes at once when none is 0xFF (a stuffed byte or a marker). The bits of the
      // bytes not taken are the same ones the next refill brings, so they may stay in the buffer.
      const std::uint64_t inverted = ~word;
      if (((inverted - 0x0101010101010101ULL) & ~inverted & 0x8080808080808080ULL) == 0) {
        bits_ |= word >> count_;
        p_ += (63 - count_) >> 3;
        count_ |= 56;
        return;
      }
    }
    while (count_ <= 56) {
      std::uint64_t byte = 0;
      if (!at_marker_ && p_ < end_ && *p_ != 0xFF) {
        byte = *p_++;
      } else if (!at_marker_ && end_ - p_ >= 2 && p_[1] == 0x00) {
        byte = 0xFF;
        p_ += 2;
      } else {
        at_marker_ = true;
        padding_ += 8;
      }
      bits_ |= byte << (56 - count_);
      count_ += 8;
    }
  }
  void RefillIfLow() {
    if (count_ < 32) Refill();
  }
  std::uint32_t Peek(int n) const { return static_cast<std::uint32_t>(bits_ >> (64 - n)); }
  void Skip(int n) {
    bits_ <<= n;
    count_ -= n;
  }
  int Take(int n) {
    const int value = static_cast<int>(bits_ >> (64 - n));
    Skip(n);
    return value;
  }
  // Whether bits past the data were decoded.
  bool OverRan() const { return count_ < padding_; }

  // Drops what is left of the restart interval and reads the restart marker RST`number`.
  bool Restart(int number) {
    bits_ = 0;
    count_ = padding_ = 0;
    at_marker_ = false;
    if (!SeekMarker()) return false;
    if (p_[1] != 0xD0 + number) return false;
    p_ += 2;
    return true;
  }
  // Moves on to the next restart marker without decoding what is before it.
  bool SkipInterval() {
    bits_ = 0;
    count_ = padding_ = 0;
    at_marker_ = false;
    return SeekMarker() && p_[1] >= 0xD0 && p_[1] <= 0xD7;
  }

 private:
  // Moves p_ to the next marker (0xFF then neither 0x00 nor another 0xFF); false if none.
  bool SeekMarker() {
    while (true) {
      const void* ff = std::memchr(p_, 0xFF, static_cast<std::size_t>(end_ - p_));
      if (ff == nullptr) return false;
      p_ = static_cast<const std::uint8_t*>(ff);
      if (end_ - p_ < 2) return false;
      if (p_[1] != 0x00 && p_[1] != 0xFF) return true;
      ++p_;
    }
  }

  const std::uint8_t* p_;
  const std::uint8_t* end_;
  std::uint64_t bits_ = 0;  // buffered bits, the next one the most significant
  int count_ = 0;  // bits buffered
  int padding_ = 0;  // of which zeros fed past the data
  bool at_marker_ = false;
};

// Eight floats as one SIMD register (GCC's and Clang's vector extension): a block's row.
using Row = float __attribute__((vector_size(32)));

// The 8 x 8 inverse DCT's basis: kBasis[k][x] = C(k) / 2 cos((2x + 1) k pi / 16), C(0) = 1/sqrt(2).
struct IdctBasis {
  Row m[8];
  IdctBasis() {
    for (int k = 0; k < 8; ++k) {
      for (int x = 0; x < 8; ++x) {
        const double c = k == 0 ? std::numbers::sqrt2 / 2 : 1.0;
        m[k][x] = static_cast<float>(c / 2 * std::cos((2 * x + 1) * k * std::numbers::pi / 16));
      }
    }
  }
};
const IdctBasis kBasis;

// A block's dequantised coefficients, natural (row-major) order, as decoded one at a time. Floats
// in memory: the transform multiplies each by a row of the basis, loading it broadcast.
struct alignas(32) Coefficients {
  float values[64];
  void Clear() { std::memset(values, 0, sizeof(values)); }
  void ClearRow(int v) { std::memset(values + 8 * v, 0, 8 * sizeof(values[0])); }
};

// The pixels of `levels` (grey levels less 128) rounded to the nearest and clamped to 0-255.
void StoreLevels(const Row& levels, std::uint8_t* out) {
  const Row shifted = levels + 128.5f;  // truncating a value >= 0 then rounds it
#if defined(__AVX2__)
  const __m256i ints = _mm256_cvttps_epi32(shifted);
  const __m128i shorts = _mm_packs_epi32(_mm256_castsi256_si128(ints), _mm256_extracti128_si256(ints, 1));
  _mm_storel_epi64(reinterpret_cast<__m128i*>(out), _mm_packus_epi16(shorts, shorts));  // saturates to 0-255
#else
  for (int x = 0; x < 8; ++x) out[x] = static_cast<std::uint8_t>(std::clamp(shifted[x], 0.0f, 255.0f));
#endif
}

// The block's pixels from its coefficients (the rows with a non-zero one flagged in `rows`, which
// are cleared), with the part [x_begin, x_end) x [y_begin, y_end) of the
// block written to `out` (its top-left pixel). Separable: each coefficient row's 1-D transform
// across, then their sum weighted down the columns; the sums split in independent chains.
void InverseDct(Coefficients& coefs, unsigned rows, int x_begin, int x_end, int y_begin,
                int y_end, std::uint8_t* out, std::size_t step) {
  // Every index constant once unrolled, so that the rows stay in registers.
  Row pixels[8];
#pragma GCC unroll 8
  for (int y = 0; y < 8; ++y) pixels[y] = Row{};
  for (int v = 0; v < 8; ++v) {
    if (!(rows >> v & 1)) continue;
    const float* c = coefs.values + 8 * v;
    const Row across = (c[0] * kBasis.m[0] + c[1] * kBasis.m[1]) + (c[2] * kBasis.m[2] + c[3] * kBasis.m[3]) +
                       ((c[4] * kBasis.m[4] + c[5] * kBasis.m[5]) + (c[6] * kBasis.m[6] + c[7] * kBasis.m[7]));
    coefs.ClearRow(v);
#pragma GCC unroll 8
    for (int y = 0; y < 8; ++y) pixels[y] += kBasis.m[v][y] * across;
  }
  if (x_begin == 0 && x_end == 8 && y_begin == 0 && y_end == 8) {
#pragma GCC unroll 8
    for (int y = 0; y < 8; ++y) StoreLevels(pixels[y], out + static_cast<std::size_t>(y) * step);
    return;
  }
  std::uint8_t block[64];
#pragma GCC unroll 8
  for (int y = 0; y < 8; ++y) StoreLevels(pixels[y], block + 8 * y);
  for (int y = y_begin; y < y_end; ++y) {
    std::memcpy(out + static_cast<std::size_t>(y) * step + x_begin, block + 8 * y + x_begin,
                static_cast<std::size_t>(x_end - x_begin));
  }
}

}  // namespace

struct JpegLumaDecoder::Tables {
  JpegHuffmanSpec spec;
  bool ac = false;
  std::array<std::uint16_t, 1 << kLookupBits> lookup{};  // (code length << 8) | symbol; 0: longer
  // AC: (value << 16) | (run << 8) | length of code and value bits, or kEndOfBlock | length of
  // the code; 0: not in kLookupBits
  std::array<std::int32_t, 1 << kLookupBits> value_lookup{};
  std::array<std::int32_t, 18> max_code{};  // the largest code of each length; -1: none
  std::array<std::int32_t, 17> first_symbol{};  // symbols[code + first_symbol[length]]

  // Builds the tables; "" or why the spec is not a Huffman table.
  std::string Build(const JpegHuffmanSpec& table, bool for_ac) {
    spec = table;
    ac = for_ac;
    int total = 0;
    for (int length = 1; length <= 16; ++length) total += spec.counts[length];
    if (total > 256) return fmt::format("a Huffman table of {} codes (256 at most)", total);
    int code = 0, index = 0;
    for (int length = 1; length <= 16; ++length) {
      first_symbol[length] = index - code;
      for (int i = 0; i < spec.counts[length]; ++i, ++index, ++code) {
        if (code >= (1 << length)) return "a Huffman table with more codes than its lengths allow";
        const int symbol = spec.symbols[index];
        if (!ac && symbol > 15) return fmt::format("a DC Huffman table with a value of {} bits", symbol);
        if (length > kLookupBits) continue;
        const int spare = kLookupBits - length;
        for (int tail = 0; tail < (1 << spare); ++tail) {
          const int slot = (code << spare) | tail;
          lookup[slot] = static_cast<std::uint16_t>((length << 8) | symbol);
          const int run = symbol >> 4, size = symbol & 15;
          if (ac && symbol == 0) value_lookup[slot] = kEndOfBlock | length;
          if (ac && size != 0 && size <= spare) {
            const int value = Extend((tail >> (spare - size)) & ((1 << size) - 1), size);
            value_lookup[slot] = static_cast<std::int32_t>(static_cast<std::uint32_t>(value) << 16) | (run << 8) |
                                 (length + size);
          }
        }
      }
      max_code[length] = spec.counts[length] ? code - 1 : -1;
      code <<= 1;
    }
    max_code[17] = 0x7fffffff;  // stops the search for a code longer than 16 bits
    return "";
  }

  // The next symbol; -1 if the bits are no code of the table.
  int Decode(BitReader& bits) const {
    const int entry = lookup[bits.Peek(kLookupBits)];
    if (entry != 0) {
      bits.Skip(entry >> 8);
      return entry & 0xFF;
    }
    const int word = static_cast<int>(bits.Peek(16));
    int length = kLookupBits + 1;
    while (length <= 16 && (word >> (16 - length)) > max_code[length]) ++length;
    if (length > 16) return -1;
    const int code = word >> (16 - length);
    bits.Skip(length);
    return spec.symbols[static_cast<std::size_t>((code + first_symbol[length]) & 0xFF)];
  }
};

namespace {

using Tables = JpegLumaDecoder::Tables;

// Decodes one block's coefficients: with kKeep, dequantised by `quant` (natural order) into
// `coefs` (all 0 before), the rows holding one flagged in `rows`; else read past. False if the
// data is corrupt.
template <bool kKeep>
bool DecodeBlock(BitReader& reader, const Tables& dc, const Tables& ac, int& dc_prediction, const float* quant,
                 Coefficients* coefs, unsigned& rows) {
  // The reader's state and the rows in locals, which stores of coefficients cannot alias.
  BitReader bits = reader;
  unsigned nonzero = 0;
  bits.RefillIfLow();
  const int dc_size = dc.Decode(bits);
  if (dc_size < 0) return false;
  if (dc_size != 0) {
    // Wraps, as 16-bit coefficients do, rather than overflow on hostile data.
    dc_prediction = static_cast<int>(static_cast<unsigned>(dc_prediction) +
                                     static_cast<unsigned>(Extend(bits.Take(dc_size), dc_size)));
  }
  if constexpr (kKeep) {
    coefs->values[0] = static_cast<float>(static_cast<std::int16_t>(dc_prediction)) * quant[0];
    nonzero |= 1;
  }
  for (int k = 1; k < 64;) {
    bits.RefillIfLow();
    const std::int32_t entry = ac.value_lookup[bits.Peek(kLookupBits)];
    int run, value;
    if (entry != 0) {
      bits.Skip(entry & 0xFF);
      if (entry & kEndOfBlock) break;
      run = (entry >> 8) & 15;
      value = entry >> 16;
    } else {
      const int symbol = ac.Decode(bits);
      if (symbol < 0) return false;
      run = symbol >> 4;
      const int size = symbol & 15;
      if (size == 0) {
        if (run != 15) break;  // end of block
        k += 16;
        continue;
      }
      value = kKeep ? Extend(bits.Take(size), size) : (bits.Skip(size), 0);
    }
    k += run;
    if (k > 63) return false;
    if constexpr (kKeep) {
      const int at = kNaturalOrder[static_cast<std::size_t>(k)];
      coefs->values[at] = static_cast<float>(value) * quant[at];
      nonzero |= 1u << (at >> 3);
    }
    ++k;
  }
  reader = bits;
  rows = nonzero;
  return true;
}

// One block of an MCU: its tables, its component's DC prediction, where it lies in the MCU.
struct McuBlock {
  const Tables* dc;
  const Tables* ac;
  int component;
  bool luma;
  int x, y;  // pixels from the MCU's top-left
};

}  // namespace

// A scan has at most 8 tables (4 components), so kMaxTables never moves the ones a decode uses.
constexpr std::size_t kMaxTables = 16;

JpegLumaDecoder::JpegLumaDecoder() { tables_.reserve(kMaxTables); }
JpegLumaDecoder::~JpegLumaDecoder() = default;

bool JpegLumaDecoder::Takes(const JpegScan& scan) {
  if (scan.components.empty() || scan.components.size() > 4 || scan.width < 1 || scan.height < 1) return false;
  int max_h = 1, max_v = 1, blocks = 0, lumas = 0;
  for (const JpegScanComponent& c : scan.components) {
    if (c.h < 1 || c.h > 4 || c.v < 1 || c.v > 4) return false;
    if (c.dc_table < 0 || c.dc_table > 3 || c.ac_table < 0 || c.ac_table > 3) return false;
    if (!scan.dc[static_cast<std::size_t>(c.dc_table)] || !scan.ac[static_cast<std::size_t>(c.ac_table)]) return false;
    max_h = std::max(max_h, c.h);
    max_v = std::max(max_v, c.v);
    blocks += c.h * c.v;
    lumas += c.luma;
  }
  if (lumas != 1 || (scan.components.size() > 1 && blocks > 10)) return false;
  const auto luma = std::find_if(scan.components.begin(), scan.components.end(),
                                 [](const JpegScanComponent& c) { return c.luma; });
  return scan.components.size() == 1 || (luma->h == max_h && luma->v == max_v);
}

const Tables& JpegLumaDecoder::TablesFor(const JpegHuffmanSpec& spec, bool ac, std::string& error) {
  for (const Tables& tables : tables_) {
    if (tables.ac == ac && tables.spec == spec) return tables;
  }
  Tables& built = tables_.emplace_back();
  error = built.Build(spec, ac);
  if (!error.empty()) {
    tables_.pop_back();
    static const Tables kNone;
    return kNone;
  }
  return built;
}

std::string JpegLumaDecoder::Decode(const JpegScan& scan, const JpegPixelSpan& span, std::uint8_t* pixels,
                                    std::size_t step) {
  TAC3D_DEMAND(Takes(scan));
  TAC3D_DEMAND(span.row_begin >= 0 && span.row_begin < span.row_end && span.row_end <= scan.height);
  TAC3D_DEMAND(span.col_begin >= 0 && span.col_begin % 8 == 0 && span.col_begin < span.col_end &&
               span.col_end <= scan.width);
  // The MCU's blocks, in the order the data holds them. A camera's stream has its 2-4 tables; a
  // stream of ever-new ones starts afresh rather than grow them.
  if (tables_.size() > kMaxTables - 8) tables_.clear();
  const bool interleaved = scan.components.size() > 1;
  std::vector<McuBlock> mcu;
  int mcu_width = 8, mcu_height = 8;
  for (int i = 0; i < static_cast<int>(scan.components.size()); ++i) {
    const JpegScanComponent& c = scan.components[static_cast<std::size_t>(i)];
    std::string error;
    const Tables* dc = &TablesFor(*scan.dc[static_cast<std::size_t>(c.dc_table)], false, error);
    const Tables* ac = error.empty() ? &TablesFor(*scan.ac[static_cast<std::size_t>(c.ac_table)], true, error) : nullptr;
    if (!error.empty()) return error;
    const int across = interleaved ? c.h : 1, down = interleaved ? c.v : 1;
    for (int b = 0; b < across * down; ++b) mcu.push_back({dc, ac, i, c.luma, b % across * 8, b / across * 8});
    if (c.luma && interleaved) {
      mcu_width = 8 * c.h;
      mcu_height = 8 * c.v;
    }
  }
  const int mcus_across = (scan.width + mcu_width - 1) / mcu_width;
  const int first_row = span.row_begin / mcu_height, last_row = (span.row_end - 1) / mcu_height;
  const int first_col = span.col_begin / mcu_width, last_col = (span.col_end - 1) / mcu_width;
  const int end = (last_row + 1) * mcus_across;  // the MCUs read: down to the span's last row
  // Whether MCUs [first_mcu, past_mcu) hold a block of the span: they run along rows of MCUs.
  const auto hold_span = [&](int first_mcu, int past_mcu) {
    const int first = std::max(first_mcu, first_row * mcus_across);
    for (int row = first / mcus_across; row * mcus_across < past_mcu; ++row) {
      const int from = std::max(first, row * mcus_across) - row * mcus_across;
      const int to = std::min(past_mcu, (row + 1) * mcus_across) - row * mcus_across;  // past the last
      if (from <= last_col && to > first_col) return true;
    }
    return false;
  };
  float quant[64];
  for (int i = 0; i < 64; ++i) quant[i] = scan.luma_quant[static_cast<std::size_t>(i)];

  BitReader bits(scan.data, scan.size);
  std::array<int, 4> predictions{};
  Coefficients coefs;  // all 0 between blocks: InverseDct clears what DecodeBlock wrote
  coefs.Clear();
  const int interval = scan.restart_interval;
  int row = 0, col = 0;  // of MCU m
  const auto advance = [&](int mcus) {
    col += mcus;
    row += col / mcus_across;
    col %= mcus_across;
  };
  for (int m = 0, restarts = 0, next_restart = interval > 0 ? 0 : end; m < end;) {
    if (m == next_restart) {
      if (m > 0 && !bits.Restart(restarts++ % 8)) return fmt::format("restart marker {} is missing", restarts - 1);
      predictions.fill(0);
      const int interval_end = std::min(m + interval, end);
      next_restart = interval_end;
      if (!hold_span(m, interval_end)) {
        if (interval_end == end) break;
        if (!bits.SkipInterval()) return fmt::format("restart marker {} is missing", restarts % 8);
        advance(interval_end - m);
        m = interval_end;
        continue;
      }
    }
    const bool in_span = row >= first_row && col >= first_col && col <= last_col;
    for (const McuBlock& block : mcu) {
      int& prediction = predictions[static_cast<std::size_t>(block.component)];
      const int x0 = col * mcu_width + block.x, y0 = row * mcu_height + block.y;
      const int x_begin = std::max(x0, span.col_begin), x_end = std::min(x0 + 8, span.col_end);
      const int y_begin = std::max(y0, span.row_begin), y_end = std::min(y0 + 8, span.row_end);
      unsigned rows = 0;
      if (block.luma && in_span && x_begin < x_end && y_begin < y_end) {
        if (!DecodeBlock<true>(bits, *block.dc, *block.ac, prediction, quant, &coefs, rows)) {
          return fmt::format("its compressed data is corrupt (MCU row {})", row);
        }
        InverseDct(coefs, rows, x_begin - x0, x_end - x0, y_begin - y0, y_end - y0,
                   pixels + static_cast<std::size_t>(y0) * step + x0, step);
      } else if (!DecodeBlock<false>(bits, *block.dc, *block.ac, prediction, nullptr, nullptr, rows)) {
        return fmt::format("its compressed data is corrupt (MCU row {})", row);
      }
    }
    if (bits.OverRan()) return fmt::format("its compressed data ends early (MCU row {})", row);
    advance(1);
    ++m;
  }
  return "";
}

}  // namespace internal
}  // namespace tac3d
