#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace tac3d {

/// Conditions the pipeline reports with a frame; bits of TactileFrame::flags.
enum class FrameFlag : std::uint32_t {
  kMarkersLost = 1u << 0,             ///< at least one marker has valid == false
  kGridReacquired = 1u << 1,          ///< tracking lost the grid and found it again this frame
  kDisplacementOutOfRange = 1u << 2,  ///< a displacement beyond the calibrated range
  kForceOutOfRange = 1u << 3,         ///< a resultant beyond the sensor's rated range
  kInitializing = 1u << 4,            ///< initialize_progress < 100: reference not yet taken
  kZeroed = 1u << 5,                  ///< the reference was retaken (a `$C`) for this frame
  kLightingChanged = 1u << 6,         ///< lighting or marker contrast far from the reference's
  kDriftAtRest = 1u << 7,             ///< the markers drifted at rest since the reference
};

/// Every flag, in bit order (for printing and iteration).
inline constexpr FrameFlag kAllFrameFlags[] = {FrameFlag::kMarkersLost,
                                               FrameFlag::kGridReacquired,
                                               FrameFlag::kDisplacementOutOfRange,
                                               FrameFlag::kForceOutOfRange,
                                               FrameFlag::kInitializing,
                                               FrameFlag::kZeroed,
                                               FrameFlag::kLightingChanged,
                                               FrameFlag::kDriftAtRest};

/// snake_case name of a flag ("markers_lost"), as the wire header's msg and logs show it.
const char* FrameFlagName(FrameFlag flag);

/// The contact's slip state (docs/slip.md): from the contact's mean traction ratio
/// |sum F_t| / sum F_n against its median marker ratio, and its frame-to-frame motion.
enum class SlipState : std::uint8_t {
  kUnknown = 0,      ///< not estimated (a version-1 recording, a frame from another sender)
  kNone = 1,         ///< no contact (fewer contact markers than SlipOptions::min_contact_markers)
  kStick = 2,        ///< the contact moves with the object (no saturated annulus seen)
  kPartialSlip = 3,  ///< a saturated annulus around a stuck core
  kGrossSlip = 4,    ///< the whole contact saturated and sliding
};
inline constexpr int kNumSlipStates = 5;

/// snake_case name ("partial_slip"), as the JSON lines show it.
const char* SlipStateName(SlipState state);

/// The per-frame slip estimate a TactileFrame carries (SlipEstimator, src/tac3d/slip/).
struct FrameSlip {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  SlipState state = SlipState::kUnknown;
  double fraction = kNaN;        ///< slipping / contact markers, NaN without contact
  /// Friction coefficient mu: in gross slip the contact's ratio, in partial slip the friction
  /// cone at the slipping annulus (docs/slip.md); NaN in stick, without contact or unknown.
  double friction = kNaN;
  double friction_sigma = kNaN;  ///< its 1-sigma uncertainty, NaN when friction is
  /// Margin to gross slip 1 - |Q| / (mu P) (Q, P: the contact's tangential and normal load):
  /// 1 unloaded, 0 sliding; NaN when friction is.
  double margin = kNaN;
  double margin_sigma = kNaN;  ///< its 1-sigma uncertainty, NaN when margin is
  /// The least normal force (N) that holds the present tangential load with
  /// SlipOptions::safety_factor: safety_factor * |Q| / mu; NaN when friction is.
  double least_normal_force_n = kNaN;

  /// Bitwise equal values (NaN equals NaN), so a frame equals its round trip.
  bool operator==(const FrameSlip& other) const;
};

/// The pipeline's output for one camera frame: what the Tac3D stream, the recorder and the
/// viewer consume. Per-marker vectors hold rows * cols entries in row-major grid order
/// (index row * cols + col), sensor frame, millimetres and newtons.
struct TactileFrame {
  std::string sn;            ///< sensor serial number, e.g. "AD2-0065L"
  std::int64_t index = 0;    ///< frame counter since the stream started
  double timestamp_s = 0.0;  ///< seconds since the stream started
  int rows = 20;
  int cols = 20;
  std::vector<Eigen::Vector3d> positions_mm;      ///< deformed marker positions
  std::vector<Eigen::Vector3d> displacements_mm;  ///< position minus reference position
  std::vector<Eigen::Vector3d> forces_n;          ///< force on each marker's surface patch
  std::vector<Eigen::Vector3d> normals;           ///< outward unit surface normals
  std::vector<bool> valid;                        ///< false: the marker was not measured this frame
  std::vector<bool> contact;                      ///< true: the marker's patch is in contact
  Eigen::Vector3d resultant_force_n = Eigen::Vector3d::Zero();  ///< sum of forces_n
  /// Sum of p_i x f_i about the sensor origin, in N mm (p_i = positions_mm[i]).
  Eigen::Vector3d resultant_moment_nmm = Eigen::Vector3d::Zero();
  int initialize_progress = 100;  ///< 0..100; consumers drop frames below 100
  std::uint32_t flags = 0;        ///< FrameFlag bits
  FrameSlip slip;                 ///< the contact's slip state and friction estimate

  /// The most marker rows or columns a frame has: a sensor's limit
  /// (SensorLimits::kMaxMarkersPerSide), so a frame's size is bounded whoever makes it.
  static constexpr int kMaxGridSide = 100;

  /// A frame with every per-marker vector sized rows * cols (zero vectors, all valid, no
  /// contact). @throws Error unless rows, cols are in 1..kMaxGridSide.
  static TactileFrame Sized(int rows, int cols);

  int num_markers() const { return rows * cols; }
  bool has(FrameFlag flag) const { return (flags & static_cast<std::uint32_t>(flag)) != 0; }
  void set(FrameFlag flag, bool on = true);

  /// @throws Error naming the field when a per-marker vector is not rows * cols long,
  /// rows or cols outside 1..kMaxGridSide, initialize_progress is outside 0..100, the timestamp is not finite, or
  /// flags holds an unknown bit, or slip's state is not a SlipState, or a valid marker's position, displacement
  /// or force is not finite (a marker measured as NaN is lost: valid false; a normal may be NaN, "not measured").
  void Validate() const;

  bool operator==(const TactileFrame&) const = default;
};

/// Space-separated names of the flags set in `flags` ("" when none).
std::string FrameFlagNames(std::uint32_t flags);

}  // namespace tac3d
