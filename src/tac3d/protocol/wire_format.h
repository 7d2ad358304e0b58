#pragma once

#include <Eigen/Core>
#include <array>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tac3d/frame/tactile_frame.h"
#include "tac3d/util/error.h"

namespace tac3d {

// The Tac3D wire protocol (docs/protocol.md): a frame is one text-header datagram followed
// by packet_count body datagrams, each prefixed with an 8-byte little-endian header.
inline constexpr std::size_t kDatagramPrefixBytes = 8;
inline constexpr std::size_t kMaxDatagramBytes = 1400;
inline constexpr std::size_t kChunkBytes = kMaxDatagramBytes - kDatagramPrefixBytes;  // 1392

/// The field names vendor clients expect (wire-protocol.md, "The fields clients expect").
inline constexpr const char* kFieldPositions = "3D_Positions";
inline constexpr const char* kFieldDisplacements = "3D_Displacements";
inline constexpr const char* kFieldForces = "3D_Forces";
inline constexpr const char* kFieldNormals = "3D_Normals";
inline constexpr const char* kFieldResultantForce = "3D_ResultantForce";
inline constexpr const char* kFieldResultantMoment = "3D_ResultantMoment";
inline constexpr const char* kFieldInitializeProgress = "InitializeProgress";
inline constexpr const char* kFieldImage = "img";
/// tac3d's extra items (docs/protocol.md, "Extra items"): the slip estimate, TactileFrame::slip.
/// Named items of the format's own types, so the vendor's Python clients decode them into their
/// per-frame dictionary by name and never read them (its C++ client complains: ExtraItem).
inline constexpr const char* kFieldSlipState = "SlipState";          ///< i32, SlipState's value
inline constexpr const char* kFieldSlipFraction = "SlipFraction";    ///< f64, NaN without contact
inline constexpr const char* kFieldFriction = "Friction";  ///< f64, NaN in stick or no contact
inline constexpr const char* kFieldFrictionSigma = "FrictionSigma";  ///< f64, 1-sigma of Friction
/// mat f64 1 x 3: FrameSlip's margin to gross slip, its 1-sigma and the least normal force (N).
/// One item, not three: each item costs its header lines, and the header must fit in one
/// datagram (docs/protocol.md).
inline constexpr const char* kFieldSlipMargin = "SlipMargin";

/// The items the vendor's processing program sends by default, in its order (its per-sensor
/// sensor.yaml): what every frame of ours carries first.
inline constexpr std::array<const char*, 6> kVendorItems = {kFieldDisplacements,
                                                            kFieldPositions,
                                                            kFieldForces,
                                                            kFieldResultantForce,
                                                            kFieldResultantMoment,
                                                            kFieldInitializeProgress};

/// tac3d's items beyond the vendor's six, each sent only when asked (StreamOptions::items),
/// after the six, in this order. The vendor's C++ client complains of each in every frame.
enum class ExtraItem {
  kNormals,
  kSlipState,
  kSlipFraction,
  kFriction,
  kFrictionSigma,
  kSlipMargin,
};
inline constexpr int kNumExtraItems = static_cast<int>(ExtraItem::kSlipMargin) + 1;
/// A set of extra items, bit ExtraItem.
using ExtraItems = std::bitset<kNumExtraItems>;
/// The item's name on the wire: kFieldNormals, kFieldSlipState, ...
const char* ExtraItemName(ExtraItem item);
/// Reads a list of extra items as `--udp-items` takes it: names (ExtraItemName) separated by
/// commas, or "all"; "" is none.
/// @param what names the setting in messages ("--udp-items").
/// @throws Error naming an item that is not an extra one (a vendor item is always sent) and
///   listing the extra ones.
ExtraItems ParseExtraItems(std::string_view text, std::string_view what);

/// The 8-byte prefix of every datagram.
struct DatagramPrefix {
  std::uint32_t frame_id = 0;
  std::uint16_t packet_count = 0;  ///< body datagrams, not counting the text header's
  std::uint16_t packet_index = 0;  ///< 0: text header; 1..packet_count: body chunks

  std::array<std::uint8_t, kDatagramPrefixBytes> Bytes() const;
  /// @pre bytes holds at least kDatagramPrefixBytes.
  static DatagramPrefix Parse(const std::uint8_t* bytes);
};

/// One frame as the sender puts it on the wire. Reused between frames, so encoding a frame
/// allocates nothing once the buffers have grown.
struct EncodedFrame {
  std::uint32_t frame_id = 0;
  std::string header;  ///< the YAML text header, the payload of datagram 0
  std::string body;    ///< the joined binary body the header's offsets point into

  int packet_count() const {
    return static_cast<int>((body.size() + kChunkBytes - 1) / kChunkBytes);
  }
  /// Datagram k's prefix and payload (k = 0: the header; k >= 1: body chunk k).
  /// @pre 0 <= k <= packet_count().
  DatagramPrefix Prefix(int k) const;
  std::string_view Payload(int k) const;
  /// Every datagram, prefix and payload joined (for tests and tools; the sender does not copy).
  std::vector<std::string> Datagrams() const;
};

/// Encodes a frame as the vendor's processing program does (docs/protocol.md): its six items
/// in its order (kVendorItems: per-marker fields rows*cols x 3 float64 row-major; resultant
/// force N and moment N mm as 1 x 3; InitializeProgress as f64), then the extra items in
/// `extras` (3D_Normals as the per-marker fields, SlipState i32, SlipFraction, Friction and
/// FrictionSigma f64, SlipMargin 1 x 3), then `img` as PNG when `image` is not empty. The header's msg holds
/// FrameFlagNames(frame.flags).
/// @param image 8-bit, 1 or 3 channels, or empty for none.
/// @throws Error if the frame does not Validate(), its SN is not printable ASCII without
/// quotes or backslashes, the header does not fit in one datagram, the image is not 8-bit
/// or the body needs more than 65535 datagrams.
void EncodeFrame(const TactileFrame& frame,
                 std::uint32_t frame_id,
                 const cv::Mat& image,
                 ExtraItems extras,
                 EncodedFrame* out);

/// The 2-byte commands a client sends back to the address frames came from.
enum class SensorCommand {
  kZero,  ///< "$C": take the present state as undeformed (cancels drift)
  kStop,  ///< "$Q": stop the sensor process
};
std::string_view CommandBytes(SensorCommand command);
/// The command a datagram holds, or nullopt unless it is exactly "$C" or "$Q".
std::optional<SensorCommand> ParseCommand(std::span<const std::uint8_t> datagram);

/// What was wrong with a datagram or a frame the client dropped (docs/protocol.md).
enum class DropReason {
  kShortDatagram,      ///< datagram: fewer bytes than the 8-byte prefix
  kOversizedDatagram,  ///< datagram: more than 1400 bytes
  kBadPacketIndex,     ///< datagram: packet_index > packet_count
  kFrameTooLarge,      ///< datagram: packet_count * 1392 exceeds the client's max_frame_bytes
  kBadChunkSize,       ///< datagram: a body chunk other than the last is not 1392 bytes
  kInconsistentCount,  ///< datagram: packet_count differs from the frame's earlier datagrams
  kDuplicate,          ///< datagram: this packet_index of this frame was already received
  kBadHeader,          ///< frame: the text header is not YAML or lacks SN, index, timestamp, data
  kBadField,           ///< frame: an item's type, dtype, shape, offset or length is wrong
  kBadImage,           ///< frame: an img item that OpenCV cannot decode
  kTimedOut,           ///< frame: still incomplete after the timeout
  kEvicted,            ///< frame: dropped to keep at most max_in_progress frames in progress
};
inline constexpr int kNumDropReasons = static_cast<int>(DropReason::kEvicted) + 1;
const char* DropReasonName(DropReason reason);

/// A frame or datagram the decoder refuses, with the reason it is counted under.
class DecodeError : public Error {
 public:
  DecodeError(DropReason reason, const std::string& what) : Error(what), reason_(reason) {}
  DropReason reason() const { return reason_; }

 private:
  DropReason reason_;
};

using RowMajorMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class FieldType { kMat, kF64, kI32, kImg };

/// One decoded data item.
struct DecodedField {
  FieldType type = FieldType::kMat;
  RowMajorMatrixXd matrix;  ///< kMat: height x width; kF64 and kI32: 1 x 1 holding the value
  cv::Mat image;            ///< kImg: as cv::imdecode returns it (unchanged depth and channels)
};

/// A frame as a client sees it.
struct DecodedFrame {
  std::string sn;
  std::int64_t index = 0;
  double timestamp_s = 0.0;  ///< the sender's timestamp (vendor clients: sendTimestamp)
  std::string msg;           ///< empty when the header has none (senders before 3.3.0)
  std::map<std::string, DecodedField, std::less<>> fields;
  /// The extra items' slip estimate; state kUnknown and NaNs when the sender sent none (a
  /// vendor sensor, an older tac3d).
  FrameSlip slip;

  /// The field called `name`, or nullptr.
  const DecodedField* Find(std::string_view name) const;
};

/// Decodes a reassembled frame: the text header and the joined body. Checks every item's
/// offset and length against the body, a mat's dtype (f64) and height * width * 8 == length,
/// f64 and i32 lengths, that images decode, and the table's fields' shapes (per-marker
/// fields N x 3 with one N, resultants 1 x 3, InitializeProgress i32 or f64), and fills `slip`
/// from the extra items (SlipState an i32 naming a SlipState, SlipMargin a 1 x 3 mat, the
/// others f64).
/// @throws DecodeError with kBadHeader, kBadField or kBadImage, saying what was wrong.
DecodedFrame DecodeFrame(std::string_view header, std::string_view body);

}  // namespace tac3d
