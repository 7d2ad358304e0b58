#include "tac3d/tracking/single_view_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include <Eigen/Dense>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Neighbours along the lattice are within this many median nearest distances (diagonal
// neighbours of a square grid are at 1.41).
constexpr double kStepReach = 1.25;
// A blob is the lattice's next one within this fraction of the median nearest distance of
// where a step predicts it.
constexpr double kStepGate = 0.3;
// A centroid's disk reaches this far past a dot's radius (blur and margin), px.
constexpr double kDiskMarginPx = 2.5;

double Median(std::vector<double> v) {
  TAC3D_DEMAND(!v.empty());
  const auto mid = v.begin() + v.size() / 2;
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

struct Lattice {
  Eigen::Vector2d column_step, row_step;
  std::map<std::pair<int, int>, int> blob_at;  // (row, col) -> blob
};

// The two steps of the lattice: the medians of the offsets to the near neighbours, folded
// along either image axis (right along the rows, down along the columns).
Lattice FindSteps(const std::vector<Eigen::Vector2d>& centers, double& nearest_px) {
  const size_t m = centers.size();
  std::vector<double> nearest(m, std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < m; ++i) {
    for (size_t j = 0; j < m; ++j) {
      if (i != j) nearest[i] = std::min(nearest[i], (centers[j] - centers[i]).norm());
    }
  }
  nearest_px = Median(nearest);
  std::vector<double> ax, ay, bx, by;
  for (size_t i = 0; i < m; ++i) {
    for (size_t j = 0; j < m; ++j) {
      const Eigen::Vector2d v = centers[j] - centers[i];
      if (i == j || v.norm() > kStepReach * nearest_px) continue;
      if (std::abs(v.x()) >= std::abs(v.y()) && v.x() > 0) {
        ax.push_back(v.x());
        ay.push_back(v.y());
      } else if (std::abs(v.y()) > std::abs(v.x()) && v.y() > 0) {
        bx.push_back(v.x());
        by.push_back(v.y());
      }
    }
  }
  if (ax.empty() || bx.empty()) {
    throw Error(fmt::format("marker grid: the {} dark blobs form no lattice (no neighbours along both "
                            "image axes)", m));
  }
  return {{Median(ax), Median(ay)}, {Median(bx), Median(by)}, {}};
}

// Each blob's lattice coordinates, walking one step at a time from the blob nearest
// `centre`.
void WalkLattice(const std::vector<Eigen::Vector2d>& centers, double nearest_px, const Eigen::Vector2d& centre,
                 Lattice& lattice) {
  const int m = static_cast<int>(centers.size());
  int start = 0;
  for (int i = 1; i < m; ++i) {
    if ((centers[i] - centre).norm() < (centers[start] - centre).norm()) start = i;
  }
  std::vector<std::pair<int, int>> coord(m);
  std::vector<std::uint8_t> placed(m, 0);
  std::vector<int> queue = {start};
  placed[start] = 1;
  coord[start] = {0, 0};
  lattice.blob_at[{0, 0}] = start;
  const double gate = kStepGate * nearest_px;
  for (size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head];
    for (const auto& [dr, dc] : {std::pair{0, 1}, std::pair{0, -1}, std::pair{1, 0}, std::pair{-1, 0}}) {
      const std::pair<int, int> at = {coord[i].first + dr, coord[i].second + dc};
      if (lattice.blob_at.count(at)) continue;
      const Eigen::Vector2d expected = centers[i] + dc * lattice.column_step + dr * lattice.row_step;
      int best = -1;
      for (int k = 0; k < m; ++k) {
        if (placed[k] || (centers[k] - expected).norm() > gate) continue;
        if (best < 0 || (centers[k] - expected).norm() < (centers[best] - expected).norm()) best = k;
      }
      if (best < 0) continue;
      placed[best] = 1;
      coord[best] = at;
      lattice.blob_at[at] = best;
      queue.push_back(best);
    }
  }
}

// The lattice's pixel at (row, col): an affine map fitted to the whole blobs.
struct LatticeMap {
  Eigen::Matrix<double, 3, 2> affine;
  Eigen::Vector2d operator()(int r, int c) const { return (Eigen::RowVector3d(c, r, 1.0) * affine).transpose(); }
};

LatticeMap FitLattice(const std::map<std::pair<int, int>, int>& whole_at, const std::vector<Eigen::Vector2d>& centers) {
  Eigen::MatrixXd design(whole_at.size(), 3);
  Eigen::MatrixXd target(whole_at.size(), 2);
  int k = 0;
  for (const auto& [at, i] : whole_at) {
    design.row(k) << at.second, at.first, 1.0;
    target.row(k++) = centers[i].transpose();
  }
  return {design.colPivHouseholderQr().solve(target)};
}

// Whether a dot cut by the image's border lies at a lattice node `p` that has no detected
// blob: its disk reaches into the image, and a dark blob there (whatever its shape: detection
// refuses most cut dots) reaches the border, along which it lies where the lattice puts it.
bool CutDotAt(const cv::Mat& image, const Eigen::Vector2d& p, double nearest_px, double disk_px,
              const BlobOptions& options) {
  const double r = disk_px - kDiskMarginPx;  // the dot's radius
  if (p.x() + r < -0.5 || p.y() + r < -0.5 || p.x() - r > image.cols - 0.5 || p.y() - r > image.rows - 0.5) {
    return false;
  }
  const cv::Rect whole(0, 0, image.cols, image.rows);
  Blob blob;
  if (MeasureBlob(image, whole, p, kStepGate * nearest_px + r, disk_px, options, blob) == BlobStatus::kNoBlob) {
    return false;
  }
  const std::uint8_t sides = BlobReachesBorder(image, whole, blob, disk_px);
  const Eigen::Vector2d off = blob.center - p;
  const double gate = kStepGate * nearest_px;
  return sides != 0 && ((sides & kBorderColumns) || std::abs(off.x()) <= gate) &&
         ((sides & kBorderRows) || std::abs(off.y()) <= gate);
}

// The tracker's options for the grid's dots: its blob options sized to them, and where the
// dots are smaller than the pitch fraction assumes, the centroid's disk narrowed to them (the
// dots' radius plus 2.5 px of blur and margin).
MarkerTrackerOptions NarrowedToDots(MarkerTrackerOptions options, const MarkerGrid& grid) {
  options.blob = grid.blob;
  const double pitch = std::min(grid.column_step_px.norm(), grid.row_step_px.norm());
  options.blob_radius = std::min(options.blob_radius, (grid.dot_radius_px + kDiskMarginPx) / pitch);
  return options;
}

}  // namespace

BlobOptions SizeBlobOptionsToDots(const BlobOptions& options, double spread_px) {
  // The defaults' largest RMS radius is twice a Tac3D dot's.
  const double scale = spread_px / (options.max_spread_px / 2);
  BlobOptions sized = ScaleBlobOptions(options, scale);
  if (scale > 1) sized.max_elongation = std::max(options.max_elongation, 4.0);
  return sized;
}

MarkerGrid FindMarkerGrid(const cv::Mat& image, int rows, int cols, const BlobOptions& blob_options) {
  if (rows < 0 || cols < 0 || rows > kMaxMarkerGridSide || cols > kMaxMarkerGridSide) {
    throw Error(fmt::format("marker grid: {} x {} markers must be within 0 .. {} a side (0 finds the size from "
                            "the image)",
                            rows, cols, kMaxMarkerGridSide));
  }
  if (image.empty() || image.type() != CV_8UC1) {
    throw Error("marker grid: the reference frame must be a non-empty 8-bit single channel image");
  }
  const cv::Rect whole(0, 0, image.cols, image.rows);
  // The dots' size first, with room for dots up to a sixteenth of the image's side.
  const int side = std::min(image.cols, image.rows);
  BlobOptions probe = blob_options;
  probe.max_spread_px = std::max(probe.max_spread_px, side / 16.0);
  probe.max_area_px = std::max(probe.max_area_px, side * side / 64);
  probe.background_kernel_px = std::max(probe.background_kernel_px, side / 16 * 2 + 1);
  std::vector<double> spreads;
  for (const Blob& b : DetectBlobs(image, whole, probe)) spreads.push_back(b.spread_px);
  if (spreads.size() < 4) {
    throw Error(fmt::format("marker grid: {} dark blobs in the reference frame, a grid needs at least 4",
                            spreads.size()));
  }
  const BlobOptions sized = SizeBlobOptionsToDots(blob_options, Median(spreads));
  const std::vector<Blob> blobs = DetectBlobs(image, whole, sized);
  if (blobs.size() < 4) {
    throw Error(fmt::format("marker grid: {} dark blobs in the reference frame, a grid needs at least 4",
                            blobs.size()));
  }
  std::vector<Eigen::Vector2d> centers;
  spreads.clear();
  for (const Blob& b : blobs) {
    centers.push_back(b.center);
    spreads.push_back(b.spread_px);
  }
  double nearest_px = 0;
  Lattice lattice = FindSteps(centers, nearest_px);
  WalkLattice(centers, nearest_px, Eigen::Vector2d(image.cols - 1, image.rows - 1) / 2, lattice);
  if (lattice.blob_at.size() < 4) {
    throw Error(fmt::format("marker grid: only {} of the {} dark blobs lie on a lattice", lattice.blob_at.size(),
                            blobs.size()));
  }

  MarkerGrid grid;
  grid.dot_radius_px = 2 * Median(spreads);
  grid.blob = sized;
  grid.column_step_px = lattice.column_step;
  grid.row_step_px = lattice.row_step;
  const double disk_px = grid.dot_radius_px + kDiskMarginPx;  // as the tracker's
  std::map<std::pair<int, int>, int> whole_at;
  for (const auto& [at, i] : lattice.blob_at) {
    if (!BlobReachesBorder(image, whole, blobs[i], disk_px)) whole_at[at] = i;
  }
  if (whole_at.size() < 3) {
    throw Error(fmt::format("marker grid: only {} blobs of the lattice are whole", whole_at.size()));
  }
  const LatticeMap map = FitLattice(whole_at, centers);
  // The markers seen: the lattice's blobs, and the dots cut by the border that detection's
  // shape checks refused, around it as far as a given grid could reach.
  int r_min = 0, r_max = 0, c_min = 0, c_max = 0;
  for (const auto& [at, i] : lattice.blob_at) {
    r_min = std::min(r_min, at.first);
    r_max = std::max(r_max, at.first);
    c_min = std::min(c_min, at.second);
    c_max = std::max(c_max, at.second);
  }
  const int reach_r = std::max(1, rows - (r_max - r_min + 1)), reach_c = std::max(1, cols - (c_max - c_min + 1));
  std::set<std::pair<int, int>> seen;
  for (const auto& [at, i] : lattice.blob_at) seen.insert(at);
  for (int r = r_min - reach_r; r <= r_max + reach_r; ++r) {
    for (int c = c_min - reach_c; c <= c_max + reach_c; ++c) {
      if (!seen.count({r, c}) && CutDotAt(image, map(r, c), nearest_px, disk_px, sized)) seen.insert({r, c});
    }
  }
  for (const auto& [r, c] : seen) {
    r_min = std::min(r_min, r);
    r_max = std::max(r_max, r);
    c_min = std::min(c_min, c);
    c_max = std::max(c_max, c);
  }
  // The extent: the markers seen, or the window of the given size holding the most of them;
  // of equals, the one with the most whole dots (a sliver of a dot at one edge against whole
  // ones at the other), then the most centred.
  grid.rows = rows > 0 ? rows : r_max - r_min + 1;
  grid.cols = cols > 0 ? cols : c_max - c_min + 1;
  int best_r0 = r_min, best_c0 = c_min, best_seen = -1, best_whole = -1, best_offcentre = 0;
  for (int r0 = std::min(r_min, r_max - grid.rows + 1); r0 <= std::max(r_min, r_max - grid.rows + 1); ++r0) {
    for (int c0 = std::min(c_min, c_max - grid.cols + 1); c0 <= std::max(c_min, c_max - grid.cols + 1); ++c0) {
      auto inside = [&](const std::pair<int, int>& at) {
        return at.first >= r0 && at.first < r0 + grid.rows && at.second >= c0 && at.second < c0 + grid.cols;
      };
      const int count = static_cast<int>(std::count_if(seen.begin(), seen.end(), inside));
      int whole_count = 0;
      for (const auto& [at, i] : whole_at) whole_count += inside(at);
      const int offcentre = std::abs(2 * r0 + grid.rows - 1 - r_min - r_max) +
                            std::abs(2 * c0 + grid.cols - 1 - c_min - c_max);
      if (std::tie(count, whole_count, best_offcentre) > std::tie(best_seen, best_whole, offcentre)) {
        best_seen = count;
        best_whole = whole_count;
        best_offcentre = offcentre;
        best_r0 = r0;
        best_c0 = c0;
      }
    }
  }
  // A grid given larger than the image shows would leave most of its markers lost (a wrong
  // --grid), not measured.
  if (2 * best_seen < grid.rows * grid.cols) {
    throw Error(fmt::format("marker grid: the {} x {} grid given holds only {} markers of the reference frame's "
                            "lattice, which spans {} x {}: is the grid right?",
                            grid.rows, grid.cols, best_seen, r_max - r_min + 1, c_max - c_min + 1));
  }

  // Markers with a whole blob sit at it; the others (no blob, or one cut by the border,
  // whose centroid is pulled inward) where an affine map of the lattice's whole blobs puts
  // them, moved by their detected neighbours' mean residual from it (a local distortion).
  const int n = grid.rows * grid.cols;
  grid.uv.assign(n, Eigen::Vector2d::Zero());
  grid.detected.assign(n, 0);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const auto it = whole_at.find({best_r0 + r, best_c0 + c});
      if (it == whole_at.end()) continue;
      grid.uv[r * grid.cols + c] = centers[it->second];
      grid.detected[r * grid.cols + c] = 1;
    }
  }
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      if (grid.detected[r * grid.cols + c]) continue;
      Eigen::Vector2d residual = Eigen::Vector2d::Zero();
      int support = 0;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if (rr < 0 || rr >= grid.rows || cc < 0 || cc >= grid.cols || !grid.detected[rr * grid.cols + cc]) continue;
          residual += grid.uv[rr * grid.cols + cc] - map(best_r0 + rr, best_c0 + cc);
          ++support;
        }
      }
      grid.uv[r * grid.cols + c] = map(best_r0 + r, best_c0 + c) + (support > 0 ? residual / support : residual);
    }
  }
  return grid;
}

SingleViewTracker::SingleViewTracker(const cv::Mat& reference, int rows, int cols,
                                     const MarkerTrackerOptions& options)
    : grid_(FindMarkerGrid(reference, rows, cols, options.blob)),
      options_(NarrowedToDots(options, grid_)),
      tracker_(grid_.rows, grid_.cols, cv::Rect(0, 0, reference.cols, reference.rows), grid_.uv, options_,
               "the image") {
  Track(reference, reference_);
}

void SingleViewTracker::Track(const cv::Mat& image, GridObservation& observation) {
  CheckTrackerImage(image, tracker_.roi().width, tracker_.roi().height);
  tracker_.Track(image, observation);
}

}  // namespace tac3d
