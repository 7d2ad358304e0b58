#include "tac3d/tracking/grid_indexer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/QR>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

// Points hashed into square cells, for neighbour queries in O(1) each.
class PointBuckets {
 public:
  PointBuckets(const std::vector<Eigen::Vector2d>& points, double cell_px)
      : cell_(cell_px) {
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(0), hi = lo;
    if (!points.empty()) {
      lo = hi = points.front();
      for (const auto& p : points) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    }
    origin_ = lo;
    nx_ = static_cast<int>((hi.x() - lo.x()) / cell_) + 1;
    ny_ = static_cast<int>((hi.y() - lo.y()) / cell_) + 1;
    start_.assign(nx_ * ny_ + 1, 0);
    for (const auto& p : points) ++start_[Cell(p) + 1];
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    order_.resize(points.size());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (int i = 0; i < static_cast<int>(points.size()); ++i) order_[fill[Cell(points[i])]++] = i;
  }

  // Calls f(index) for every point within `radius` of q (and a few more, by cell).
  template <typename F>
  void ForNear(const Eigen::Vector2d& q, double radius, F&& f) const {
    const int cx0 = std::max(0, static_cast<int>(std::floor((q.x() - radius - origin_.x()) / cell_)));
    const int cy0 = std::max(0, static_cast<int>(std::floor((q.y() - radius - origin_.y()) / cell_)));
    const int cx1 = std::min(nx_ - 1, static_cast<int>(std::floor((q.x() + radius - origin_.x()) / cell_)));
    const int cy1 = std::min(ny_ - 1, static_cast<int>(std::floor((q.y() + radius - origin_.y()) / cell_)));
    for (int cy = cy0; cy <= cy1; ++cy) {
      for (int cx = cx0; cx <= cx1; ++cx) {
        const int c = cy * nx_ + cx;
        for (int k = start_[c]; k < start_[c + 1]; ++k) f(order_[k]);
      }
    }
  }

 private:
  int Cell(const Eigen::Vector2d& p) const {
    const int cx = std::clamp(static_cast<int>((p.x() - origin_.x()) / cell_), 0, nx_ - 1);
    const int cy = std::clamp(static_cast<int>((p.y() - origin_.y()) / cell_), 0, ny_ - 1);
    return cy * nx_ + cx;
  }

  double cell_;
  Eigen::Vector2d origin_;
  int nx_ = 1, ny_ = 1;
  std::vector<int> start_, order_;
};

struct Matching {
  std::vector<int> detection_of_marker;
  int matches = 0;
  double sum_squared_px = 0.0;
};

// The matching starts in a disk of this many pitches around where the start offset fits,
// and the disk grows by this factor an iteration: a rotation or scale the start offset
// does not know about would otherwise match the grid's far parts to wrong neighbours.
constexpr double kStartRadiusPitches = 3.0;
constexpr double kRadiusGrowth = 1.5;

// Each marker predicted within `radius` of `anchor` takes its nearest detection within its
// gate; a detection claimed by several markers goes to the nearest of them.
Matching MatchOneToOne(const std::vector<Eigen::Vector2d>& predicted,
                       const std::vector<Eigen::Vector2d>& mapped,
                       const Eigen::Vector2d& anchor,
                       double radius,
                       const std::vector<Eigen::Vector2d>& detections,
                       const PointBuckets& buckets,
                       const std::vector<double>& gate_px) {
  const int n = static_cast<int>(mapped.size());
  Matching m;
  m.detection_of_marker.assign(n, -1);
  std::vector<double> best(n, std::numeric_limits<double>::infinity());
  std::vector<int> owner(detections.size(), -1);
  std::vector<double> owner_d2(detections.size(), std::numeric_limits<double>::infinity());
  for (int i = 0; i < n; ++i) {
    if ((predicted[i] - anchor).squaredNorm() > radius * radius) continue;
    const double gate2 = gate_px[i] * gate_px[i];
    buckets.ForNear(mapped[i], gate_px[i], [&](int j) {
      const double d2 = (detections[j] - mapped[i]).squaredNorm();
      if (d2 <= gate2 && d2 < best[i]) {
        best[i] = d2;
        m.detection_of_marker[i] = j;
      }
    });
    const int j = m.detection_of_marker[i];
    if (j >= 0 && best[i] < owner_d2[j]) {
      owner_d2[j] = best[i];
      owner[j] = i;
    }
  }
  for (int i = 0; i < n; ++i) {
    const int j = m.detection_of_marker[i];
    if (j < 0) continue;
    if (owner[j] != i) {
      m.detection_of_marker[i] = -1;
      continue;
    }
    ++m.matches;
    m.sum_squared_px += best[i];
  }
  return m;
}

// Least-squares affine map predicted -> detection over the matches; false if degenerate.
bool FitAffine(const std::vector<Eigen::Vector2d>& predicted,
               const std::vector<Eigen::Vector2d>& detections,
               const std::vector<int>& detection_of_marker,
               Eigen::Matrix<double, 2, 3>& affine) {
  int count = 0;
  for (int j : detection_of_marker) count += j >= 0;
  if (count < 3) return false;
  Eigen::MatrixXd a(count, 3);
  Eigen::MatrixXd b(count, 2);
  int row = 0;
  for (size_t i = 0; i < predicted.size(); ++i) {
    const int j = detection_of_marker[i];
    if (j < 0) continue;
    a.row(row) << predicted[i].x(), predicted[i].y(), 1.0;
    b.row(row) = detections[j].transpose();
    ++row;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 3) return false;
  affine = qr.solve(b).transpose();
  return true;
}

}  // namespace

void GridIndexOptions::Validate() const {
  const OptionCheck require("grid index options");
  require(max_offset_px > 0, "max_offset_px", "> 0", max_offset_px);
  require(hypotheses >= 1, "hypotheses", ">= 1", hypotheses);
  require(match_gate > 0 && match_gate < 0.5, "match_gate", "in (0, 0.5)", match_gate);
  require(max_iterations >= 1, "max_iterations", ">= 1", max_iterations);
}

std::vector<GridIndex> IndexGrid(const std::vector<Eigen::Vector2d>& detections,
                                 const std::vector<Eigen::Vector2d>& predicted,
                                 const std::vector<double>& pitch_px,
                                 const GridIndexOptions& options) {
  options.Validate();
  if (predicted.size() != pitch_px.size()) {
    throw Error(fmt::format("grid index: {} predicted markers but {} pitches", predicted.size(),
                            pitch_px.size()));
  }
  const int n = static_cast<int>(predicted.size());
  std::vector<GridIndex> candidates;
  if (detections.size() < 3 || n == 0) return candidates;

  double mean_pitch = 0;
  for (double p : pitch_px) mean_pitch += p / n;
  const PointBuckets buckets(detections, mean_pitch);
  std::vector<double> gate(n);
  for (int i = 0; i < n; ++i) gate[i] = options.match_gate * pitch_px[i];

  // Vote for the offset detection - prediction on a 1 px grid, smoothed by a 5 x 5 box so
  // a small rotation or scale (which smears the peak) still leaves one.
  const int reach = static_cast<int>(std::ceil(options.max_offset_px));
  const int side = 2 * reach + 1;
  Eigen::MatrixXd votes = Eigen::MatrixXd::Zero(side, side);
  for (int i = 0; i < n; ++i) {
    buckets.ForNear(predicted[i], options.max_offset_px, [&](int j) {
      const Eigen::Vector2d d = detections[j] - predicted[i];
      const int ix = static_cast<int>(std::lround(d.x())) + reach;
      const int iy = static_cast<int>(std::lround(d.y())) + reach;
      if (ix >= 0 && ix < side && iy >= 0 && iy < side) votes(iy, ix) += 1.0;
    });
  }
  Eigen::MatrixXd smooth = Eigen::MatrixXd::Zero(side, side);
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const int y0 = std::max(0, y - 2), y1 = std::min(side - 1, y + 2);
      const int x0 = std::max(0, x - 2), x1 = std::min(side - 1, x + 2);
      smooth(y, x) = votes.block(y0, x0, y1 - y0 + 1, x1 - x0 + 1).sum();
    }
  }
  // The strongest peaks, each at least half the smallest pitch from the ones before.
  double min_pitch = *std::min_element(pitch_px.begin(), pitch_px.end());
  std::vector<Eigen::Vector2d> starts;
  Eigen::MatrixXd remaining = smooth;
  while (static_cast<int>(starts.size()) < options.hypotheses) {
    Eigen::Index py, px;
    if (remaining.maxCoeff(&py, &px) <= 0) break;
    starts.emplace_back(px - reach, py - reach);
    const int clear = std::max(1, static_cast<int>(0.5 * min_pitch));
    for (int y = std::max<int>(0, py - clear); y <= std::min<int>(side - 1, py + clear); ++y) {
      for (int x = std::max<int>(0, px - clear); x <= std::min<int>(side - 1, px + clear); ++x) {
        remaining(y, x) = 0;
      }
    }
  }

  std::vector<Eigen::Vector2d> mapped(n);
  auto map_all = [&](const Eigen::Matrix<double, 2, 3>& affine) {
    for (int i = 0; i < n; ++i) mapped[i] = affine.leftCols<2>() * predicted[i] + affine.col(2);
  };
  const double everywhere = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector2d& start : starts) {
    Eigen::Matrix<double, 2, 3> affine;
    affine << 1, 0, start.x(), 0, 1, start.y();
    // Where the start offset fits: the matched marker with the most matched markers
    // within the starting disk (a rotation makes the offset fit along a band only).
    map_all(affine);
    Matching matching = MatchOneToOne(predicted, mapped, Eigen::Vector2d::Zero(), everywhere,
                                      detections, buckets, gate);
    double radius = kStartRadiusPitches * mean_pitch;
    Eigen::Vector2d anchor = Eigen::Vector2d::Zero();
    int densest = 0;
    for (int i = 0; i < n; ++i) {
      if (matching.detection_of_marker[i] < 0) continue;
      int around = 0;
      for (int k = 0; k < n; ++k) {
        around += matching.detection_of_marker[k] >= 0 &&
                  (predicted[k] - predicted[i]).squaredNorm() <= radius * radius;
      }
      if (around > densest) {
        densest = around;
        anchor = predicted[i];
      }
    }
    double full_radius = 0;
    for (const auto& p : predicted) full_radius = std::max(full_radius, (p - anchor).norm());
    int iterations = 0;
    bool fitted = false;
    for (iterations = 1; iterations <= options.max_iterations; ++iterations) {
      map_all(affine);
      const bool whole = radius > full_radius;
      Matching next = MatchOneToOne(predicted, mapped, anchor, whole ? everywhere : radius,
                                    detections, buckets, gate);
      const bool converged = whole && fitted && next.detection_of_marker == matching.detection_of_marker;
      matching = std::move(next);
      if (converged) break;
      if (!FitAffine(predicted, detections, matching.detection_of_marker, affine)) break;
      fitted = true;
      radius *= kRadiusGrowth;
    }
    if (!fitted) continue;
    const bool seen = std::any_of(candidates.begin(), candidates.end(), [&](const GridIndex& c) {
      return c.detection_of_marker == matching.detection_of_marker;
    });
    if (seen) continue;
    GridIndex& index = candidates.emplace_back();
    index.detection_of_marker = std::move(matching.detection_of_marker);
    index.affine = affine;
    index.summary.start_offset_px = start;
    index.summary.iterations = std::min(iterations, options.max_iterations);
    index.summary.matches = matching.matches;
    index.summary.rms_px = std::sqrt(matching.sum_squared_px / std::max(1, matching.matches));
  }
  std::stable_sort(candidates.begin(), candidates.end(), [](const GridIndex& a, const GridIndex& b) {
    return a.summary.matches > b.summary.matches ||
           (a.summary.matches == b.summary.matches && a.summary.rms_px < b.summary.rms_px);
  });
  return candidates;
}

}  // namespace tac3d
