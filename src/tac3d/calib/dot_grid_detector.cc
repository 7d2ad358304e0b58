#include "tac3d/calib/dot_grid_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "tac3d/util/error.h"

namespace tac3d {
namespace {

using IndexMap = std::function<std::array<int, 2>(int, int)>;

// The orderings of the detected dots that describe the same board: index permutations p of
// the grid (reordered[i] = detected[p[i]]) that keep every distance between dots, i.e. the
// board turned or flipped onto itself.
std::vector<std::vector<int>> GridSymmetries(const CalibrationBoard& board) {
  const int rows = board.rows, cols = board.cols;
  std::vector<IndexMap> maps = {
      [](int r, int c) { return std::array<int, 2>{r, c}; },
      [&](int r, int c) { return std::array<int, 2>{rows - 1 - r, cols - 1 - c}; },
      [&](int r, int c) { return std::array<int, 2>{rows - 1 - r, c}; },
      [&](int r, int c) { return std::array<int, 2>{r, cols - 1 - c}; }};
  if (rows == cols) {
    maps.push_back([](int r, int c) { return std::array<int, 2>{c, r}; });
    maps.push_back([&](int r, int c) { return std::array<int, 2>{cols - 1 - c, rows - 1 - r}; });
    maps.push_back([&](int r, int c) { return std::array<int, 2>{c, rows - 1 - r}; });
    maps.push_back([&](int r, int c) { return std::array<int, 2>{cols - 1 - c, r}; });
  }
  const std::vector<Eigen::Vector3d> x = board.DotCenters();
  const int n = rows * cols;
  std::vector<std::vector<int>> symmetries;
  for (const IndexMap& map : maps) {
    std::vector<int> p(n);
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const auto [pr, pc] = map(r, c);
        p[r * cols + c] = pr * cols + pc;
      }
    }
    bool congruent = true;
    for (int i = 0; i < n && congruent; ++i) {
      for (int j = i + 1; j < n && congruent; ++j) {
        congruent = std::abs((x[p[i]] - x[p[j]]).norm() - (x[i] - x[j]).norm()) <
                    1e-9 * board.spacing_mm;
      }
    }
    if (congruent) symmetries.push_back(std::move(p));
  }
  return symmetries;
}

// How well an ordering's rows run to the right and its columns down (at most 2).
double OrderScore(const std::vector<Eigen::Vector2d>& d, int rows, int cols) {
  Eigen::Vector2d along_row = Eigen::Vector2d::Zero(), down_column = Eigen::Vector2d::Zero();
  for (int r = 0; r < rows; ++r) along_row += d[r * cols + cols - 1] - d[r * cols];
  for (int c = 0; c < cols; ++c) down_column += d[(rows - 1) * cols + c] - d[c];
  return along_row.normalized().x() + down_column.normalized().y();
}

struct DotWindow {
  Eigen::Matrix2d image_from_board;  // local affine map of the grid, px per mm
  Eigen::Matrix2d board_from_image;
  double radius_mm;                  // window radius on the board
  double ring_mm;                    // background ring starts here
};

// The darkness-weighted centroid around `center`, and the dot's edge width.
void RefineDot(const cv::Mat& gray, const cv::Rect& roi, const DotWindow& w,
               Eigen::Vector2d& center, double& edge_width_px) {
  const double half_u = w.radius_mm * w.image_from_board.row(0).norm();
  const double half_v = w.radius_mm * w.image_from_board.row(1).norm();
  for (int iteration = 0; iteration < 3; ++iteration) {
    const int u0 = std::max(roi.x + 1, static_cast<int>(std::floor(center.x() - half_u)));
    const int u1 = std::min(roi.x + roi.width - 2, static_cast<int>(std::ceil(center.x() + half_u)));
    const int v0 = std::max(roi.y + 1, static_cast<int>(std::floor(center.y() - half_v)));
    const int v1 = std::min(roi.y + roi.height - 2, static_cast<int>(std::ceil(center.y() + half_v)));
    if (u1 <= u0 || v1 <= v0) return;
    // The white level around the dot as a plane a + b u + c v, so vignetting's slope does
    // not pull the centroid towards the brighter side.
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    std::vector<std::array<int, 2>> inside;
    int darkest = 255, ring_count = 0;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const double r = (w.board_from_image * (Eigen::Vector2d(u, v) - center)).norm();
        if (r > w.radius_mm) continue;
        const std::uint8_t value = gray.at<std::uint8_t>(v, u);
        inside.push_back({u, v});
        darkest = std::min<int>(darkest, value);
        if (r >= w.ring_mm) {
          const Eigen::Vector3d a(1.0, u - center.x(), v - center.y());
          normal += a * a.transpose();
          rhs += a * value;
          ++ring_count;
        }
      }
    }
    if (ring_count < 3 || std::abs(normal.determinant()) < 1e-9) return;
    const Eigen::Vector3d plane = normal.ldlt().solve(rhs);
    if (!(plane(0) > 0)) return;
    double sum = 0, su = 0, sv = 0, steepest = 0;
    for (const auto& [u, v] : inside) {
      const double white = plane(0) + plane(1) * (u - center.x()) + plane(2) * (v - center.y());
      // The fraction of the light the dot takes away: its coverage of the pixel.
      const double darkness = std::max(0.0, 1.0 - gray.at<std::uint8_t>(v, u) / white);
      sum += darkness;
      su += darkness * u;
      sv += darkness * v;
      const double gu = 0.5 * (gray.at<std::uint8_t>(v, u + 1) - gray.at<std::uint8_t>(v, u - 1));
      const double gv = 0.5 * (gray.at<std::uint8_t>(v + 1, u) - gray.at<std::uint8_t>(v - 1, u));
      steepest = std::max(steepest, std::hypot(gu, gv));
    }
    if (sum <= 0) return;
    center = {su / sum, sv / sum};
    if (steepest > 0) edge_width_px = (plane(0) - darkest) / steepest;
  }
}

}  // namespace

DotGridDetection DetectDotGrid(const cv::Mat& gray, const cv::Rect& roi,
                               const CalibrationBoard& board) {
  TAC3D_DEMAND(gray.type() == CV_8UC1);
  TAC3D_DEMAND((roi & cv::Rect(0, 0, gray.cols, gray.rows)) == roi);
  board.Validate();
  DotGridDetection out;

  // The default blob detector wants dots of 25 px or more, 10 px apart; board dots seen
  // obliquely through the mirrors are smaller and closer, and their pixelised outlines
  // less convex.
  cv::SimpleBlobDetector::Params params;
  params.minArea = 8;
  params.maxArea = 0.05f * roi.area();
  params.minDistBetweenBlobs = 3;
  params.minConvexity = 0.8f;
  std::vector<cv::KeyPoint> keypoints;
  cv::SimpleBlobDetector::create(params)->detect(gray(roi), keypoints);
  const int n = board.rows * board.cols;
  out.blobs = static_cast<int>(keypoints.size());
  if (out.blobs < n || out.blobs > kMaxDotGridBlobsPerDot * n) return out;
  std::vector<cv::Point2f> candidates;
  candidates.reserve(keypoints.size());
  for (const cv::KeyPoint& k : keypoints) candidates.push_back(k.pt);
  std::vector<cv::Point2f> found;
  const int flags = board.layout == CalibrationBoard::Layout::kSymmetric
                        ? cv::CALIB_CB_SYMMETRIC_GRID
                        : cv::CALIB_CB_ASYMMETRIC_GRID;
  // The default grid finder gives up on strongly foreshortened views that the clustering
  // one orders correctly. Both take the candidates detected once above (no detector).
  const cv::Size pattern(board.cols, board.rows);
  if (!cv::findCirclesGrid(candidates, pattern, found, flags, nullptr) &&
      !cv::findCirclesGrid(candidates, pattern, found, flags | cv::CALIB_CB_CLUSTERING, nullptr)) {
    return out;
  }
  TAC3D_DEMAND(static_cast<int>(found.size()) == n);
  std::vector<Eigen::Vector2d> detected(n);
  for (int i = 0; i < n; ++i) detected[i] = {found[i].x + roi.x, found[i].y + roi.y};

  double best_score = -std::numeric_limits<double>::infinity();
  for (const std::vector<int>& p : GridSymmetries(board)) {
    std::vector<Eigen::Vector2d> ordered(n);
    for (int i = 0; i < n; ++i) ordered[i] = detected[p[i]];
    const double score = OrderScore(ordered, board.rows, board.cols);
    if (score > best_score) {
      best_score = score;
      out.centers = std::move(ordered);
    }
  }

  const std::vector<Eigen::Vector3d> x = board.DotCenters();
  const double radius_mm = 0.5 * board.NearestDotDistance();
  const double dot_radius_mm = 0.5 * board.dot_diameter_mm;
  std::vector<double> edge_widths;
  std::vector<Eigen::Vector2d> refined(n);
  for (int r = 0; r < board.rows; ++r) {
    for (int c = 0; c < board.cols; ++c) {
      // Affine fit image = A * board + t over the dot and its grid neighbours.
      Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
      Eigen::Matrix<double, 3, 2> rhs = Eigen::Matrix<double, 3, 2>::Zero();
      for (int rr = std::max(0, r - 1); rr <= std::min(board.rows - 1, r + 1); ++rr) {
        for (int cc = std::max(0, c - 1); cc <= std::min(board.cols - 1, c + 1); ++cc) {
          const int j = rr * board.cols + cc;
          const Eigen::Vector3d a(x[j].x(), x[j].y(), 1.0);
          normal += a * a.transpose();
          rhs += a * out.centers[j].transpose();
        }
      }
      const Eigen::Matrix<double, 3, 2> solution = normal.lu().solve(rhs);
      DotWindow w;
      w.image_from_board = solution.topRows<2>().transpose();
      w.board_from_image = w.image_from_board.inverse();
      w.radius_mm = radius_mm;
      w.ring_mm = 0.5 * (dot_radius_mm + radius_mm);
      const int i = r * board.cols + c;
      refined[i] = out.centers[i];
      double edge_width = std::numeric_limits<double>::quiet_NaN();
      RefineDot(gray, roi, w, refined[i], edge_width);
      if (std::isfinite(edge_width)) edge_widths.push_back(edge_width);
    }
  }
  out.centers = std::move(refined);
  if (!edge_widths.empty()) {
    std::nth_element(edge_widths.begin(), edge_widths.begin() + edge_widths.size() / 2,
                     edge_widths.end());
    out.edge_width_px = edge_widths[edge_widths.size() / 2];
  }
  out.found = true;
  return out;
}

Eigen::Vector2d DotCentroidBias(const CameraIntrinsics& camera, const Rigid3& cam_from_board,
                                const Eigen::Vector3d& dot, double radius_mm) {
  Eigen::Matrix3d h;  // board plane (x, y, 1) -> camera ray
  h << cam_from_board.linear().col(0), cam_from_board.linear().col(1),
      cam_from_board.translation();
  Eigen::Matrix3d circle;
  circle << 1, 0, -dot.x(), 0, 1, -dot.y(), -dot.x(), -dot.y(),
      dot.head<2>().squaredNorm() - radius_mm * radius_mm;
  const Eigen::Matrix3d h_inverse = h.inverse();
  const Eigen::Matrix3d conic = h_inverse.transpose() * circle * h_inverse;
  const Eigen::Vector2d center =
      -conic.topLeftCorner<2, 2>().inverse() * conic.topRightCorner<2, 1>();
  return camera.Project(Eigen::Vector3d(center.x(), center.y(), 1.0)) -
         camera.Project(cam_from_board * dot);
}

}  // namespace tac3d
