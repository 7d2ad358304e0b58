#include "tac3d/tracking/blob_detector.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Directions (cos, sin) of the background samples around a blob (one vector of them).
constexpr int kRingSamples = 16;
struct RingDirections {
  std::array<double, kRingSamples> cos, sin;  // two arrays, so scaling them vectorises
};
const RingDirections kRingDirections = [] {
  RingDirections d;
  for (int k = 0; k < kRingSamples; ++k) {
    d.cos[k] = std::cos(2 * M_PI * k / kRingSamples);
    d.sin[k] = std::sin(2 * M_PI * k / kRingSamples);
  }
  return d;
}();

// Rows are read 16 pixels at a time as one vector (GCC and Clang vector extensions: SSE or
// AVX2 on x86-64, NEON on ARM), so a dot's row costs a few instructions, not a loop.
constexpr int kLanes = 16;
using U8x16 = std::uint8_t __attribute__((vector_size(kLanes)));
using I32x8 = std::int32_t __attribute__((vector_size(2 * kLanes)));
constexpr U8x16 kLane = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
static_assert(kRingSamples == kLanes, "the background ring is one vector");
static_assert(std::endian::native == std::endian::little, "FirstLaneEqual reads lane 0 as the lowest byte");

// The column a vector covering pixels from x0 on starts at: x0, or less so that it stays
// inside the row.
int VectorStart(int cols, int x0) { return std::max(0, std::min(x0, cols - kLanes)); }

// Pixels [x0, x1] of a row into lanes from column `first` on (first <= x0, x1 < first +
// kLanes, inside the image); the other lanes are white (255).
void LoadSpan(const std::uint8_t* row, int cols, int first, int x0, int x1, U8x16& pixels) {
  if (first + kLanes <= cols) {
    std::memcpy(&pixels, row + first, kLanes);
  } else {  // an image narrower than a vector
    for (int k = 0; k < kLanes; ++k) pixels[k] = first + k < cols ? row[first + k] : 255;
  }
  const auto lo = static_cast<std::uint8_t>(x0 - first), hi = static_cast<std::uint8_t>(x1 - first);
  pixels |= reinterpret_cast<U8x16>(~((kLane >= lo) & (kLane <= hi)));
}

U8x16 Min(U8x16 a, U8x16 b) { return a < b ? a : b; }

int HorizontalMin(U8x16 v) {
  v = Min(v, __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7));
  v = Min(v, __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3));
  v = Min(v, __builtin_shufflevector(v, v, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1));
  v = Min(v, __builtin_shufflevector(v, v, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0));
  return v[0];
}

bool AnyLaneEqual(U8x16 v, std::uint8_t value) {
  const auto equal = v == value;
  std::uint64_t half[2];
  std::memcpy(half, &equal, sizeof(half));
  return (half[0] | half[1]) != 0;
}

// The lowest lane holding `value` (at least one does).
int FirstLaneEqual(U8x16 v, std::uint8_t value) {
  const auto equal = v == value;
  std::uint64_t half[2];
  std::memcpy(half, &equal, sizeof(half));
  return half[0] != 0 ? std::countr_zero(half[0]) / 8 : 8 + std::countr_zero(half[1]) / 8;
}

// The value at 0-based `rank` of the lanes in ascending order: the smallest value that more
// than `rank` lanes are at or below (16 compares of all lanes, no sort).
int ValueAtRank(U8x16 v, int rank) {
  U8x16 at_or_below{};
  for (int j = 0; j < kLanes; ++j) at_or_below -= reinterpret_cast<U8x16>(v[j] <= v);
  return HorizontalMin(at_or_below > static_cast<std::uint8_t>(rank) ? v : U8x16{} + 255);
}

std::int64_t Sum(I32x8 v) {
  v += __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v += __builtin_shufflevector(v, v, 2, 3, 0, 1, 2, 3, 0, 1);
  v += __builtin_shufflevector(v, v, 1, 0, 1, 0, 1, 0, 1, 0);
  return v[0];
}

// A vector's 16 lanes as two halves of 32-bit integers.
struct I32x16 {
  I32x8 lo{}, hi{};
};
I32x16 Widen(U8x16 v) {
#if defined(__AVX2__)
  // GCC lowers the generic conversion below lane by lane; AVX2 widens 8 bytes in one instruction.
  const __m128i bytes = reinterpret_cast<__m128i>(v);
  return {reinterpret_cast<I32x8>(_mm256_cvtepu8_epi32(bytes)),
          reinterpret_cast<I32x8>(_mm256_cvtepu8_epi32(_mm_unpackhi_epi64(bytes, bytes)))};
#else
  return {__builtin_convertvector(__builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7), I32x8),
          __builtin_convertvector(__builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15), I32x8)};
#endif
}
constexpr I32x8 kLaneLo = {0, 1, 2, 3, 4, 5, 6, 7}, kLaneHi = {8, 9, 10, 11, 12, 13, 14, 15};

// A centroid this far (squared, px^2) from the disk's centre is measured again about it.
constexpr double kRecentreDistance2 = 0.75 * 0.75;
// Large dots (a measuring disk of at least kLargeDiskPx): their darkest pixel, found in every
// kSearchRowStep-th row of the search disk, may lie anywhere in a flat dark core, so their
// moments start at the predicted centre; a small dot's at its darkest pixel.
constexpr double kLargeDiskPx = 8.0;
constexpr int kSearchRowStep = 3;
// How far (px) a dot's blurred rim reaches beyond twice its RMS radius.
constexpr double kDotBlurPx = 2.5;
// A prediction off by more than the disk's margin needs a pass to find the dot and one to
// centre on it.
constexpr int kMaxMomentPasses = 3;

int Round(double v) { return static_cast<int>(std::floor(v + 0.5)); }

// Largest |dx| with dx^2 + dy^2 <= r2 (-1 if none): one row of a disk.
int HalfWidth(double r2, int dy) {
  const double left = r2 - dy * dy;
  return left < 0 ? -1 : static_cast<int>(std::floor(std::sqrt(left)));
}

// The blob's seed: the darkest pixel in the search disk (255 and x < 0 if none is darker
// than white).
struct Seed {
  int darkest = 255, x = -1, y = -1;
};

// The search disk's rows are scanned a block of them at a time.
constexpr int kBlockRows = 16;

// Calls f(y, first, pixels) on the vectors covering rows block + k * row_step (k < rows) from
// span_x0[k] to span_x1[k] (pixels outside the span white), in row-major order, until f returns
// true.
template <typename F>
void ForEachSpanVector(const cv::Mat& image,
                       int block,
                       int rows,
                       int row_step,
                       const std::array<int, kBlockRows>& span_x0,
                       const std::array<int, kBlockRows>& span_x1,
                       F&& f) {
  for (int k = 0; k < rows; ++k) {
    const int y = block + k * row_step, x0 = span_x0[k], x1 = span_x1[k];
    const std::uint8_t* row = image.ptr<std::uint8_t>(y);
    for (int a = x0; a <= x1; a += kLanes) {
      U8x16 pixels;
      const int first = VectorStart(image.cols, a);
      LoadSpan(row, image.cols, first, a, std::min(x1, a + kLanes - 1), pixels);
      if (f(y, first, pixels)) return;
    }
  }
}

// The darkest pixel in the disk of radius `s` about `predicted`, inside `roi`: the first, in
// row-major order, of the disk's minimum; in every kSearchRowStep-th row for a disk of at
// least kLargeDiskPx, whose dots are many rows tall (the seed need only lie in the dot).
Seed FindDarkestPixel(const cv::Mat& image,
                      const cv::Rect& roi,
                      const Eigen::Vector2d& predicted,
                      double s) {
  const int roi_x1 = roi.x + roi.width - 1, roi_y1 = roi.y + roi.height - 1;
  const double qx = predicted.x(), qy = predicted.y();
  Seed seed;
  int y0 = std::max(roi.y, static_cast<int>(std::ceil(qy - s)));
  const int y1 = std::min(roi_y1, static_cast<int>(std::floor(qy + s)));
  const int row_step = s >= kLargeDiskPx ? kSearchRowStep : 1;
  // A dot cut by the roi's last row may be a row or two tall there: that row is scanned.
  if (y1 == roi_y1 && y0 > roi.y) y0 += (y1 - y0) % row_step;
  // The rows' spans come first, a block at a time, so their square roots do not sit in the
  // scanning loop (a separate loop also vectorises).
  std::array<int, kBlockRows> span_x0, span_x1;
  for (int block = y0; block <= y1; block += kBlockRows * row_step) {
    const int rows = std::min(kBlockRows, (y1 - block) / row_step + 1);
    for (int k = 0; k < rows; ++k) {
      const double dy = block + k * row_step - qy;
      const double half_width = std::sqrt(std::max(0.0, s * s - dy * dy));
      span_x0[k] = std::max(roi.x, static_cast<int>(std::ceil(qx - half_width)));
      span_x1[k] = std::min(roi_x1, static_cast<int>(std::floor(qx + half_width)));
    }
    // The block's minimum (lane by lane, one reduction), then where it first is, if it is
    // darker than the blocks before.
    U8x16 lanes_min = U8x16{} + 255;
    ForEachSpanVector(image, block, rows, row_step, span_x0, span_x1, [&](int, int, U8x16 pixels) {
      lanes_min = Min(lanes_min, pixels);
      return false;
    });
    const int block_min = HorizontalMin(lanes_min);
    if (block_min >= seed.darkest) continue;
    seed.darkest = block_min;
    ForEachSpanVector(image, block, rows, row_step, span_x0, span_x1, [&](int y, int first, U8x16 pixels) {
      if (!AnyLaneEqual(pixels, static_cast<std::uint8_t>(block_min))) return false;
      seed.x = first + FirstLaneEqual(pixels, static_cast<std::uint8_t>(block_min));
      seed.y = y;
      return true;
    });
  }
  return seed;
}

// Local background: the median of 16 pixels on a circle just outside the blob's disk,
// robust to a neighbouring dot covering part of it. False if fewer than half the samples
// lie in the roi.
bool MeasureRingBackground(const cv::Mat& image,
                           const cv::Rect& roi,
                           const Seed& seed,
                           double blob_radius_px,
                           double& background) {
  const int roi_x1 = roi.x + roi.width - 1, roi_y1 = roi.y + roi.height - 1;
  // Samples outside the roi are white, so they sort after the others: the median of the
  // ring_size samples in it is still the one at rank ring_size / 2.
  const double ring_radius = blob_radius_px + 1.25;
  std::array<int, kRingSamples> ring_x, ring_y;  // first, apart from the reads: vectorised
  for (int k = 0; k < kRingSamples; ++k) {
    ring_x[k] = seed.x + Round(ring_radius * kRingDirections.cos[k]);
    ring_y[k] = seed.y + Round(ring_radius * kRingDirections.sin[k]);
  }
  U8x16 ring;
  int ring_size = 0;
  for (int k = 0; k < kRingSamples; ++k) {
    const int x = ring_x[k], y = ring_y[k];
    const bool inside = x >= roi.x && x <= roi_x1 && y >= roi.y && y <= roi_y1;
    ring[k] = inside ? image.ptr<std::uint8_t>(y)[x] : 255;
    ring_size += inside;
  }
  if (ring_size < kRingSamples / 2) return false;
  background = ValueAtRank(ring, ring_size / 2);
  return true;
}

// The half widths of the rows of a disk of radius r_px, tabulated once for both moment
// passes (a square root in each row's loop cost as much as the rest of it); only radii past
// the table, from full-image detection of a large component, take theirs row by row.
class DiskHalfWidths {
 public:
  explicit DiskHalfWidths(double r_px) : r2_(r_px * r_px), r_(static_cast<int>(std::floor(r_px))) {
    for (int dy = 0; dy <= std::min(r_, kTabulatedRows - 1); ++dy) table_[dy] = HalfWidth(r2_, dy);
  }
  int r() const { return r_; }
  int operator()(int dy) const {
    return std::abs(dy) < kTabulatedRows ? table_[std::abs(dy)] : HalfWidth(r2_, dy);
  }

 private:
  static constexpr int kTabulatedRows = 64;
  const double r2_;
  const int r_;
  std::array<int, kTabulatedRows> table_;
};

// Darkness-weighted moments about the integer centre (cx, cy), and how many pixels have
// weight.
struct Moments {
  int cx = 0, cy = 0;
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  std::int64_t count = 0;
};

// One pass: the moments of weight = level - pixel (clipped at 0) over the disk about
// (m.cx, m.cy), into m.
void SumDiskMoments(const cv::Mat& image,
                    const cv::Rect& roi,
                    std::uint8_t level,
                    const DiskHalfWidths& half_width_at,
                    Moments& m) {
  const int roi_x1 = roi.x + roi.width - 1, roi_y1 = roi.y + roi.height - 1;
  const int r = half_width_at.r(), cx = m.cx, cy = m.cy;
  // Exact integer moments about (cx, cy). The disk's vectors start at the same columns in
  // every row, so a pixel's dx is its lane plus the vector's offset: down a vector's rows each
  // lane sums w, w * dy and w * dy^2 (no reduction across lanes in the row loop), and the
  // lane index and the offset enter once per vector. The same integers as summing
  // w * dx^i * dy^j pixel by pixel.
  // Rows summed before the lanes are emptied into 64 bits: a lane's count is 8-bit, and
  // 16 lanes of w * dy^2 (or of w * |dy| * 15) must fit an int32.
  const std::int64_t row_bound = 255 * 16 * std::int64_t{std::max({1, 15 * r, r * r})};
  const int rows_per_flush = static_cast<int>(std::clamp<std::int64_t>(
      std::numeric_limits<std::int32_t>::max() / row_bound, 1, 255));
  std::int64_t mw = 0, mwx = 0, mwy = 0, mwxx = 0, mwxy = 0, mwyy = 0;
  std::int64_t count = 0;
  const int x_begin = std::max(cx - r, roi.x), x_end = std::min(cx + r, roi_x1);
  const int y_begin = std::max(cy - r, roi.y), y_end = std::min(cy + r, roi_y1);
  for (int a = x_begin; a <= x_end; a += kLanes) {
    const int first = VectorStart(image.cols, a), last = std::min(x_end, a + kLanes - 1);
    const std::int64_t offset = first - cx;
    I32x16 w, wy, wyy;  // per lane, down the rows
    U8x16 nonzero{};
    // Lane sums into the vector's moments: sum_l s(l) * l^power.
    auto lane_sum = [](const I32x16& s, int power) {
      I32x8 v = s.lo, u = s.hi;
      for (int p = 0; p < power; ++p) {
        v *= kLaneLo;
        u *= kLaneHi;
      }
      return Sum(v + u);
    };
    auto flush = [&] {
      const std::int64_t sw = lane_sum(w, 0), swl = lane_sum(w, 1), swll = lane_sum(w, 2);
      const std::int64_t swy = lane_sum(wy, 0), swly = lane_sum(wy, 1);
      // dx = lane + offset.
      mw += sw;
      mwx += swl + offset * sw;
      mwxx += swll + 2 * offset * swl + offset * offset * sw;
      mwy += swy;
      mwxy += swly + offset * swy;
      mwyy += lane_sum(wyy, 0);
      for (int k = 0; k < kLanes; ++k) count += nonzero[k];
      w = wy = wyy = I32x16{};
      nonzero = U8x16{};
    };
    for (int y = y_begin, rows = 0; y <= y_end; ++y) {
      const int dy = y - cy, half_width = half_width_at(dy);
      const int x0 = std::max(a, cx - half_width), x1 = std::min(last, cx + half_width);
      if (x0 > x1) continue;
      U8x16 pixels;
      LoadSpan(image.ptr<std::uint8_t>(y), image.cols, first, x0, x1, pixels);
      const U8x16 weight = pixels < level ? level - pixels : U8x16{};  // white padding: 0
      nonzero -= reinterpret_cast<U8x16>(weight != 0);
      const I32x16 row = Widen(weight);
      const I32x16 row_y = {row.lo * dy, row.hi * dy};
      w.lo += row.lo;
      w.hi += row.hi;
      wy.lo += row_y.lo;
      wy.hi += row_y.hi;
      wyy.lo += row_y.lo * dy;
      wyy.hi += row_y.hi * dy;
      if (++rows == rows_per_flush) {
        flush();
        rows = 0;
      }
    }
    flush();
  }
  m.count = count;
  m.sw = static_cast<double>(mw);
  m.sx = static_cast<double>(mwx);
  m.sy = static_cast<double>(mwy);
  m.sxx = static_cast<double>(mwxx);
  m.sxy = static_cast<double>(mwxy);
  m.syy = static_cast<double>(mwyy);
}

// The blob's centroid and shape from its moments: RMS radius along the long axis,
// elongation, and fill (pixels with weight over the covariance ellipse's area).
struct Shape {
  Eigen::Vector2d center;
  double spread, elongation, fill;
};
Shape CalcShape(const Moments& m) {
  const double sw = m.sw;
  const double mx = m.sx / sw, my = m.sy / sw;
  // A pixel is a unit square: its own variance (1/12 per axis) keeps a one-pixel blob finite.
  const double cxx = m.sxx / sw - mx * mx + 1.0 / 12, cyy = m.syy / sw - my * my + 1.0 / 12;
  const double cxy = m.sxy / sw - mx * my;
  const double mean = 0.5 * (cxx + cyy);
  const double deviation = std::sqrt(0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy);
  const double major = mean + deviation, minor = std::max(mean - deviation, 1.0 / 12);
  return {Eigen::Vector2d(m.cx + mx, m.cy + my),
          std::sqrt(major),
          std::sqrt(major / minor),
          m.count / (4.0 * M_PI * std::sqrt(major * minor))};
}

// Darkness-weighted moments over the blob's disk about `start`; again about the pixel nearest
// the centroid while the disk may have cut the dot off-centre: the centroid more than
// kRecentreDistance2 off and the dot's extent (twice its RMS radius, a flat dot's radius, plus
// kDotBlurPx) from it reaching past the disk's rim. At most kMaxMomentPasses passes. False if a
// pass has no weight.
bool CalcCentredMoments(const cv::Mat& image,
                        const cv::Rect& roi,
                        int start_x,
                        int start_y,
                        std::uint8_t level,
                        double blob_radius_px,
                        Moments& m) {
  const DiskHalfWidths half_width_at(blob_radius_px);
  m.cx = start_x;
  m.cy = start_y;
  for (int pass = 0; pass < kMaxMomentPasses; ++pass) {
    if (pass > 0) {
      const double ox = m.sx / m.sw, oy = m.sy / m.sw, offset2 = ox * ox + oy * oy;
      const double margin = blob_radius_px - 2 * CalcShape(m).spread - kDotBlurPx;
      if (offset2 <= std::max(kRecentreDistance2, margin * std::abs(margin))) break;
      m.cx += Round(ox);
      m.cy += Round(oy);
    }
    SumDiskMoments(image, roi, level, half_width_at, m);
    if (m.sw <= 0) return false;
  }
  return true;
}

// Darkness of the 3 x 3 core at `center` (the part inside the roi, `core_count` pixels):
// the sum of background - pixel.
double CoreDarkness(const cv::Mat& image,
                    const cv::Rect& roi,
                    const Eigen::Vector2d& center,
                    double background,
                    int& core_count) {
  const int roi_x1 = roi.x + roi.width - 1, roi_y1 = roi.y + roi.height - 1;
  const int ux = Round(center.x()), uy = Round(center.y());
  int core_sum = 0;  // integers: the same sum as in doubles, without its chain
  core_count = 0;
  for (int y = std::max(roi.y, uy - 1); y <= std::min(roi_y1, uy + 1); ++y) {
    for (int x = std::max(roi.x, ux - 1); x <= std::min(roi_x1, ux + 1); ++x) {
      core_sum += image.at<std::uint8_t>(y, x);
      ++core_count;
    }
  }
  return core_count * background - core_sum;
}

}  // namespace

void BlobOptions::Validate() const {
  const OptionCheck require("blob options");
  require(min_contrast_dn > 0 && min_contrast_dn < 255, "min_contrast_dn", "in (0, 255)",
          min_contrast_dn);
  require(min_relative_contrast >= 0 && min_relative_contrast < 1, "min_relative_contrast",
          "in [0, 1)", min_relative_contrast);
  require(weight_threshold >= 0 && weight_threshold < 1, "weight_threshold", "in [0, 1)",
          weight_threshold);
  require(min_spread_px >= 0, "min_spread_px", ">= 0", min_spread_px);
  require(max_spread_px > min_spread_px, "max_spread_px", "> min_spread_px", max_spread_px);
  require(max_elongation >= 1, "max_elongation", ">= 1", max_elongation);
  require(min_fill >= 0, "min_fill", ">= 0", min_fill);
  require(min_core_darkness >= 0 && min_core_darkness <= 1, "min_core_darkness", "in [0, 1]",
          min_core_darkness);
  require(background_kernel_px >= 3 && background_kernel_px % 2 == 1, "background_kernel_px",
          "odd and >= 3", background_kernel_px);
  require(min_area_px >= 1, "min_area_px", ">= 1", min_area_px);
  require(max_area_px > min_area_px, "max_area_px", "> min_area_px", max_area_px);
}

BlobOptions ScaleBlobOptions(const BlobOptions& options, double scale) {
  if (!(scale > 1)) return options;
  BlobOptions scaled = options;
  scaled.min_spread_px *= scale;
  scaled.max_spread_px *= scale;
  scaled.background_kernel_px = 2 * static_cast<int>(std::lround(0.5 * (options.background_kernel_px - 1) * scale)) + 1;
  scaled.min_area_px = static_cast<int>(std::lround(options.min_area_px * scale * scale));
  scaled.max_area_px = static_cast<int>(std::lround(options.max_area_px * scale * scale));
  return scaled;
}

std::string_view ToString(BlobStatus status) {
  switch (status) {
    case BlobStatus::kFound: return "found";
    case BlobStatus::kNoBlob: return "no blob";
    case BlobStatus::kBadShape: return "bad shape";
  }
  return "?";
}

BlobStatus MeasureBlob(const cv::Mat& image,
                       const cv::Rect& roi,
                       const Eigen::Vector2d& predicted,
                       double search_radius_px,
                       double blob_radius_px,
                       const BlobOptions& options,
                       Blob& blob) {
  TAC3D_DEMAND(image.type() == CV_8UC1);
  TAC3D_DEMAND(search_radius_px > 0 && blob_radius_px > 0);
  if (!predicted.allFinite()) return BlobStatus::kNoBlob;
  const int roi_x1 = roi.x + roi.width - 1, roi_y1 = roi.y + roi.height - 1;
  const double qx = predicted.x(), qy = predicted.y();
  const double s = search_radius_px;
  if (qx + s < roi.x || qx - s > roi_x1 || qy + s < roi.y || qy - s > roi_y1) {
    return BlobStatus::kNoBlob;
  }

  const Seed seed = FindDarkestPixel(image, roi, predicted, search_radius_px);
  // No pixel, or none darker than white (padding lanes are white): no contrast either.
  if (seed.x < 0) return BlobStatus::kNoBlob;
  double background = 0;
  if (!MeasureRingBackground(image, roi, seed, blob_radius_px, background)) {
    return BlobStatus::kNoBlob;
  }
  const double contrast = background - seed.darkest;
  if (contrast < std::max(options.min_contrast_dn, options.min_relative_contrast * background)) {
    return BlobStatus::kNoBlob;
  }

  // level <= background <= 255 and level >= darkest >= 0 (weight_threshold < 1): a byte.
  const auto level = static_cast<std::uint8_t>(Round(background - options.weight_threshold * contrast));
  Moments m;
  const bool large = blob_radius_px >= kLargeDiskPx;
  if (!CalcCentredMoments(image, roi, large ? Round(qx) : seed.x, large ? Round(qy) : seed.y, level,
                          blob_radius_px, m)) {
    return BlobStatus::kNoBlob;
  }
  const Shape shape = CalcShape(m);
  int core_count = 0;
  const double core = CoreDarkness(image, roi, shape.center, background, core_count);
  blob.center = shape.center;
  blob.background_dn = background;
  blob.contrast_dn = contrast;
  blob.spread_px = shape.spread;
  blob.elongation = shape.elongation;
  if (shape.spread < options.min_spread_px || shape.spread > options.max_spread_px ||
      shape.elongation > options.max_elongation || shape.fill < options.min_fill ||
      core < options.min_core_darkness * contrast * core_count) {
    return BlobStatus::kBadShape;
  }
  return BlobStatus::kFound;
}

void PrefetchDisk(const cv::Mat& image, const cv::Rect& roi, const Eigen::Vector2d& center, double radius_px) {
  if (!center.allFinite()) return;
  const cv::Rect box = cv::Rect(static_cast<int>(std::floor(center.x() - radius_px)),
                                static_cast<int>(std::floor(center.y() - radius_px)),
                                static_cast<int>(2 * radius_px) + 2, static_cast<int>(2 * radius_px) + 2) &
                       roi;
  constexpr int kCacheLine = 64;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const std::uint8_t* row = image.ptr<std::uint8_t>(y);
    for (int x = box.x; x < box.x + box.width; x += kCacheLine) __builtin_prefetch(row + x);
    __builtin_prefetch(row + box.x + box.width - 1);
  }
}

std::uint8_t BlobReachesBorder(const cv::Mat& image,
                               const cv::Rect& roi,
                               const Blob& blob,
                               double blob_radius_px) {
  TAC3D_DEMAND(image.type() == CV_8UC1);
  const double level = blob.background_dn - 0.5 * blob.contrast_dn;
  const double cx = blob.center.x(), cy = blob.center.y(), r2 = blob_radius_px * blob_radius_px;
  const int x0 = roi.x, x1 = roi.x + roi.width - 1, y0 = roi.y, y1 = roi.y + roi.height - 1;
  // Most dots' disks reach no border: nothing to read.
  if (cx - blob_radius_px > x0 && cx + blob_radius_px < x1 && cy - blob_radius_px > y0 &&
      cy + blob_radius_px < y1) {
    return 0;
  }
  auto weighted = [&](int x, int y) {
    return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r2 && image.at<std::uint8_t>(y, x) < level;
  };
  const int xa = std::max(x0, static_cast<int>(std::floor(cx - blob_radius_px)));
  const int xb = std::min(x1, static_cast<int>(std::ceil(cx + blob_radius_px)));
  const int ya = std::max(y0, static_cast<int>(std::floor(cy - blob_radius_px)));
  const int yb = std::min(y1, static_cast<int>(std::ceil(cy + blob_radius_px)));
  std::uint8_t sides = 0;
  for (int x = xa; x <= xb && !(sides & kBorderRows); ++x) {
    if (weighted(x, y0) || weighted(x, y1)) sides |= kBorderRows;
  }
  for (int y = ya; y <= yb && !(sides & kBorderColumns); ++y) {
    if (weighted(x0, y) || weighted(x1, y)) sides |= kBorderColumns;
  }
  return sides;
}

std::vector<Blob> DetectBlobs(const cv::Mat& image, const cv::Rect& roi, const BlobOptions& options) {
  options.Validate();
  TAC3D_DEMAND(image.type() == CV_8UC1);
  TAC3D_DEMAND((roi & cv::Rect(0, 0, image.cols, image.rows)) == roi);
  const cv::Mat view = image(roi);
  // The film without its dots: a closing wider than a dot fills them in.
  const int k = options.background_kernel_px;
  cv::Mat film;
  cv::morphologyEx(view, film, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
  cv::blur(film, film, {k, k});
  cv::Mat darkness, threshold, mask;
  cv::subtract(film, view, darkness);  // saturates at 0
  film.convertTo(threshold, CV_8U, options.min_relative_contrast);
  threshold = cv::max(threshold, options.min_contrast_dn);
  cv::compare(darkness, threshold, mask, cv::CMP_GT);

  cv::Mat labels, stats, centroids;
  const int components = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<Blob> blobs;
  for (int c = 1; c < components; ++c) {  // 0 is the background
    const int area = stats.at<int>(c, cv::CC_STAT_AREA);
    if (area < options.min_area_px || area > options.max_area_px) continue;
    const int size = std::max(stats.at<int>(c, cv::CC_STAT_WIDTH), stats.at<int>(c, cv::CC_STAT_HEIGHT));
    const Eigen::Vector2d center(roi.x + centroids.at<double>(c, 0), roi.y + centroids.at<double>(c, 1));
    Blob blob;
    if (MeasureBlob(image, roi, center, std::max(1.0, 0.5 * size), 0.5 * size + 1.0, options, blob) ==
        BlobStatus::kFound) {
      blobs.push_back(blob);
    }
  }
  return blobs;
}

}  // namespace tac3d
