#include "tac3d/protocol/wire_format.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <iterator>
#include <opencv2/imgcodecs.hpp>

namespace tac3d {
namespace {

// Fields are copied to and from the wire with memcpy: the wire is little-endian.
static_assert(std::endian::native == std::endian::little, "tac3d assumes a little-endian host");

// A decoded image may not claim more pixels than this: a few bytes of crafted PNG or JPEG
// header must not make the client allocate gigabytes.
constexpr std::int64_t kMaxImagePixels = 4096 * 4096;

constexpr const char* kPerMarkerFields[] = {
    kFieldPositions, kFieldDisplacements, kFieldForces, kFieldNormals};

// YAML floats with a '.' always, so YAML 1.1 parsers (PyYAML) also read them as numbers:
// "1" -> "1.0", "1e-05" -> "1.0e-05". The shortest round-trip digits keep the value exact.
std::string YamlFloat(double value) {
  std::string text = fmt::format("{}", value);
  if (text.find('.') != std::string::npos) return text;
  const auto e = text.find('e');
  text.insert(e == std::string::npos ? text.size() : e, ".0");
  return text;
}

void CheckSn(const std::string& sn) {
  for (const char c : sn) {
    if (c < 0x20 || c > 0x7e || c == '"' || c == '\\') {
      throw Error(fmt::format(
          "Tac3D encoder: SN '{}' must be printable ASCII without quotes or backslashes", sn));
    }
  }
}

template <typename Out>
void AppendItem(
    Out out, const char* name, const char* type, std::size_t offset, std::size_t length) {
  fmt::format_to(out,
                 "  - name: {}\n    type: {}\n    offset: {}\n    length: {}\n",
                 name,
                 type,
                 offset,
                 length);
}

template <typename Out>
void AppendMatItem(Out out, const char* name, int height, int width, std::size_t offset) {
  fmt::format_to(out,
                 "  - name: {}\n    type: mat\n    dtype: f64\n    width: {}\n    height: {}\n"
                 "    offset: {}\n    length: {}\n",
                 name,
                 width,
                 height,
                 offset,
                 sizeof(double) * height * width);
}

// Big-endian 16- and 32-bit reads for image headers.
std::uint32_t Be(const std::uint8_t* p, int bytes) {
  std::uint32_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | p[k];
  return v;
}

// Width * height an encoded PNG or JPEG declares, or nullopt when neither is recognised.
std::optional<std::int64_t> DeclaredPixels(const std::uint8_t* p, std::size_t n) {
  static constexpr std::uint8_t kPng[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n >= 24 && std::memcmp(p, kPng, sizeof(kPng)) == 0 && std::memcmp(p + 12, "IHDR", 4) == 0) {
    return std::int64_t{Be(p + 16, 4)} * Be(p + 20, 4);
  }
  if (n < 4 || p[0] != 0xff || p[1] != 0xd8) return std::nullopt;
  // JPEG: walk the marker segments to the first start-of-frame (SOF0..SOF15 but DHT, JPG, DAC).
  std::size_t i = 2;
  while (i + 4 <= n) {
    if (p[i] != 0xff) return std::nullopt;
    const std::uint8_t marker = p[i + 1];
    if (marker == 0xff) {  // fill byte
      ++i;
      continue;
    }
    if (marker >= 0xd0 && marker <= 0xd9) {  // RSTn, SOI, EOI: no length
      i += 2;
      continue;
    }
    const std::size_t length = Be(p + i + 2, 2);
    if (marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc) {
      if (i + 9 > n) return std::nullopt;
      return std::int64_t{Be(p + i + 5, 2)} * Be(p + i + 7, 2);
    }
    i += 2 + length;
  }
  return std::nullopt;
}

cv::Mat DecodeImage(const std::string& name, std::string_view bytes) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  const auto pixels = DeclaredPixels(p, bytes.size());
  if (!pixels || *pixels < 1 || *pixels > kMaxImagePixels) {
    throw DecodeError(
        DropReason::kBadImage,
        fmt::format("item '{}': not a PNG or JPEG of 1 to {} pixels", name, kMaxImagePixels));
  }
  cv::Mat image;
  try {
    const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8U, const_cast<std::uint8_t*>(p));
    image = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw DecodeError(DropReason::kBadImage,
                      fmt::format("item '{}': the image does not decode: {}", name, e.what()));
  }
  if (image.empty()) {
    throw DecodeError(DropReason::kBadImage,
                      fmt::format("item '{}': the image does not decode", name));
  }
  return image;
}

// The table's shapes (wire-protocol.md): per-marker fields N x 3 with one N for all, resultants
// 1 x 3, InitializeProgress a scalar.
void CheckTableShapes(const DecodedFrame& frame) {
  auto fail = [](const std::string& what) { throw DecodeError(DropReason::kBadField, what); };
  Eigen::Index markers = -1;
  for (const char* name : kPerMarkerFields) {
    const DecodedField* field = frame.Find(name);
    if (field == nullptr) continue;
    if (field->type != FieldType::kMat || field->matrix.cols() != 3) {
      fail(fmt::format("item '{}' must be a mat of width 3", name));
    }
    if (markers >= 0 && field->matrix.rows() != markers) {
      fail(fmt::format("item '{}' has height {}, other per-marker items {}",
                       name,
                       field->matrix.rows(),
                       markers));
    }
    markers = field->matrix.rows();
  }
  for (const char* name : {kFieldResultantForce, kFieldResultantMoment}) {
    const DecodedField* field = frame.Find(name);
    if (field != nullptr && (field->type != FieldType::kMat || field->matrix.rows() != 1 ||
                             field->matrix.cols() != 3)) {
      fail(fmt::format("item '{}' must be a 1 x 3 mat", name));
    }
  }
  const DecodedField* progress = frame.Find(kFieldInitializeProgress);
  if (progress != nullptr && progress->type != FieldType::kI32 &&
      progress->type != FieldType::kF64) {
    fail(fmt::format("item '{}' must be i32 or f64", kFieldInitializeProgress));
  }
}

// The extra items' slip estimate: each present item must have its type, SlipState a known
// value; absent ones stay unknown.
FrameSlip DecodeSlip(const DecodedFrame& frame) {
  auto fail = [](const std::string& what) { throw DecodeError(DropReason::kBadField, what); };
  FrameSlip slip;
  if (const DecodedField* state = frame.Find(kFieldSlipState)) {
    const double value = state->type == FieldType::kI32 ? state->matrix(0, 0) : -1.0;
    if (value < 0 || value >= kNumSlipStates) {
      fail(fmt::format("item '{}' must be an i32 in 0..{}", kFieldSlipState, kNumSlipStates - 1));
    }
    slip.state = static_cast<SlipState>(static_cast<int>(value));
  }
  for (const auto& [name, value] : {std::pair{kFieldSlipFraction, &slip.fraction},
                                    std::pair{kFieldFriction, &slip.friction},
                                    std::pair{kFieldFrictionSigma, &slip.friction_sigma}}) {
    const DecodedField* field = frame.Find(name);
    if (field == nullptr) continue;
    if (field->type != FieldType::kF64) fail(fmt::format("item '{}' must be f64", name));
    *value = field->matrix(0, 0);
  }
  if (const DecodedField* margin = frame.Find(kFieldSlipMargin)) {
    if (margin->type != FieldType::kMat || margin->matrix.rows() != 1 ||
        margin->matrix.cols() != 3) {
      fail(fmt::format("item '{}' must be a 1 x 3 mat", kFieldSlipMargin));
    }
    slip.margin = margin->matrix(0, 0);
    slip.margin_sigma = margin->matrix(0, 1);
    slip.least_normal_force_n = margin->matrix(0, 2);
  }
  return slip;
}

DecodedField DecodeItem(const YAML::Node& item, const std::string& name, std::string_view body) {
  auto fail = [&](const std::string& what) {
    throw DecodeError(DropReason::kBadField, fmt::format("item '{}': {}", name, what));
  };
  const auto type = item["type"].as<std::string>();
  const auto offset = item["offset"].as<std::int64_t>();
  const auto length = item["length"].as<std::int64_t>();
  const auto body_size = static_cast<std::int64_t>(body.size());
  if (offset < 0 || length < 0 || offset > body_size || length > body_size - offset) {
    fail(fmt::format("offset {} + length {} outside the {}-byte body", offset, length, body_size));
  }
  const char* data = body.data() + offset;
  DecodedField field;
  if (type == "mat") {
    field.type = FieldType::kMat;
    const auto dtype = item["dtype"].as<std::string>();
    if (dtype != "f64") fail(fmt::format("dtype '{}', only f64 is defined", dtype));
    const auto width = item["width"].as<std::int64_t>();
    const auto height = item["height"].as<std::int64_t>();
    // Bounding each side by the body size keeps the product from overflowing.
    if (width < 1 || height < 1 || width > body_size || height > body_size ||
        width * height * static_cast<std::int64_t>(sizeof(double)) != length) {
      fail(fmt::format("{} x {} f64 does not match length {}", height, width, length));
    }
    field.matrix.resize(height, width);
    std::memcpy(field.matrix.data(), data, length);
  } else if (type == "f64" || type == "i32") {
    const bool is_f64 = type == "f64";
    field.type = is_f64 ? FieldType::kF64 : FieldType::kI32;
    const std::int64_t expected = is_f64 ? sizeof(double) : sizeof(std::int32_t);
    if (length != expected) fail(fmt::format("{} needs length {}, not {}", type, expected, length));
    field.matrix.resize(1, 1);
    if (is_f64) {
      std::memcpy(field.matrix.data(), data, sizeof(double));
    } else {
      std::int32_t value;
      std::memcpy(&value, data, sizeof(value));
      field.matrix(0, 0) = value;
    }
  } else if (type == "img") {
    field.type = FieldType::kImg;
    field.image = DecodeImage(name, std::string_view(data, length));
  } else {
    fail(fmt::format("unknown type '{}'", type));
  }
  return field;
}

// One scalar item: its header entry and its bytes.
template <typename T>
void AppendScalar(const char* name, const char* type, T value, EncodedFrame* out) {
  AppendItem(std::back_inserter(out->header), name, type, out->body.size(), sizeof(value));
  out->body.append(reinterpret_cast<const char*>(&value), sizeof(value));
}

// A rows x 3 float64 matrix item.
void AppendMat(const char* name, const double* values, int height, EncodedFrame* out) {
  AppendMatItem(std::back_inserter(out->header), name, height, 3, out->body.size());
  out->body.append(reinterpret_cast<const char*>(values), sizeof(double) * 3 * height);
}

// kVendorItems, in that order; InitializeProgress as f64, as the vendor sends it.
void AppendVendorItems(const TactileFrame& frame, EncodedFrame* out) {
  const int n = frame.num_markers();
  AppendMat(kFieldDisplacements, frame.displacements_mm.front().data(), n, out);
  AppendMat(kFieldPositions, frame.positions_mm.front().data(), n, out);
  AppendMat(kFieldForces, frame.forces_n.front().data(), n, out);
  AppendMat(kFieldResultantForce, frame.resultant_force_n.data(), 1, out);
  AppendMat(kFieldResultantMoment, frame.resultant_moment_nmm.data(), 1, out);
  AppendScalar(
      kFieldInitializeProgress, "f64", static_cast<double>(frame.initialize_progress), out);
}

void AppendExtraItems(const TactileFrame& frame, ExtraItems extras, EncodedFrame* out) {
  const auto has = [&](ExtraItem item) { return extras.test(static_cast<int>(item)); };
  if (has(ExtraItem::kNormals)) {
    AppendMat(kFieldNormals, frame.normals.front().data(), frame.num_markers(), out);
  }
  if (has(ExtraItem::kSlipState)) {
    AppendScalar(kFieldSlipState, "i32", static_cast<std::int32_t>(frame.slip.state), out);
  }
  for (const auto& [item, value] :
       {std::pair{ExtraItem::kSlipFraction, frame.slip.fraction},
        std::pair{ExtraItem::kFriction, frame.slip.friction},
        std::pair{ExtraItem::kFrictionSigma, frame.slip.friction_sigma}}) {
    if (has(item)) AppendScalar(ExtraItemName(item), "f64", value, out);
  }
  if (has(ExtraItem::kSlipMargin)) {
    const double margin[3] = {
        frame.slip.margin, frame.slip.margin_sigma, frame.slip.least_normal_force_n};
    AppendMat(kFieldSlipMargin, margin, 1, out);
  }
}

void AppendImage(const cv::Mat& image, EncodedFrame* out) {
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw Error(
        fmt::format("Tac3D encoder: the image must be 8-bit with 1 or 3 channels, not "
                    "depth {} with {} channels",
                    image.depth(),
                    image.channels()));
  }
  std::vector<std::uint8_t> png;
  cv::imencode(".png", image, png);
  AppendItem(std::back_inserter(out->header), kFieldImage, "img", out->body.size(), png.size());
  out->body.append(reinterpret_cast<const char*>(png.data()), png.size());
}

}  // namespace

const char* DropReasonName(DropReason reason) {
  switch (reason) {
    case DropReason::kShortDatagram:
      return "short_datagram";
    case DropReason::kOversizedDatagram:
      return "oversized_datagram";
    case DropReason::kBadPacketIndex:
      return "bad_packet_index";
    case DropReason::kFrameTooLarge:
      return "frame_too_large";
    case DropReason::kBadChunkSize:
      return "bad_chunk_size";
    case DropReason::kInconsistentCount:
      return "inconsistent_count";
    case DropReason::kDuplicate:
      return "duplicate";
    case DropReason::kBadHeader:
      return "bad_header";
    case DropReason::kBadField:
      return "bad_field";
    case DropReason::kBadImage:
      return "bad_image";
    case DropReason::kTimedOut:
      return "timed_out";
    case DropReason::kEvicted:
      return "evicted";
  }
  TAC3D_DEMAND(false);
}

const char* ExtraItemName(ExtraItem item) {
  switch (item) {
    case ExtraItem::kNormals:
      return kFieldNormals;
    case ExtraItem::kSlipState:
      return kFieldSlipState;
    case ExtraItem::kSlipFraction:
      return kFieldSlipFraction;
    case ExtraItem::kFriction:
      return kFieldFriction;
    case ExtraItem::kFrictionSigma:
      return kFieldFrictionSigma;
    case ExtraItem::kSlipMargin:
      return kFieldSlipMargin;
  }
  TAC3D_DEMAND(false);
}

ExtraItems ParseExtraItems(std::string_view text, std::string_view what) {
  std::vector<std::string> names;
  for (int k = 0; k < kNumExtraItems; ++k)
    names.push_back(ExtraItemName(static_cast<ExtraItem>(k)));
  ExtraItems items;
  for (std::size_t begin = 0; !text.empty() && begin <= text.size();) {
    const std::size_t comma = std::min(text.find(',', begin), text.size());
    const std::string_view name = text.substr(begin, comma - begin);
    begin = comma + 1;
    if (name == "all") {
      items.set();
      continue;
    }
    const auto it = std::find(names.begin(), names.end(), name);
    if (it != names.end()) {
      items.set(it - names.begin());
      continue;
    }
    const bool vendor =
        std::find(kVendorItems.begin(), kVendorItems.end(), name) != kVendorItems.end();
    throw Error(fmt::format("{} '{}': {}; the items to add to the vendor's six are {} (or all)",
                            what,
                            text,
                            vendor
                                ? fmt::format("'{}' is one of the vendor's six, always sent", name)
                                : fmt::format("unknown item '{}'", name),
                            fmt::join(names, ", ")));
  }
  return items;
}

std::string_view CommandBytes(SensorCommand command) {
  return command == SensorCommand::kZero ? "$C" : "$Q";
}

std::optional<SensorCommand> ParseCommand(std::span<const std::uint8_t> datagram) {
  const std::string_view text(reinterpret_cast<const char*>(datagram.data()), datagram.size());
  if (text == "$C") return SensorCommand::kZero;
  if (text == "$Q") return SensorCommand::kStop;
  return std::nullopt;
}

std::array<std::uint8_t, kDatagramPrefixBytes> DatagramPrefix::Bytes() const {
  std::array<std::uint8_t, kDatagramPrefixBytes> bytes;
  std::memcpy(bytes.data(), &frame_id, 4);
  std::memcpy(bytes.data() + 4, &packet_count, 2);
  std::memcpy(bytes.data() + 6, &packet_index, 2);
  return bytes;
}

DatagramPrefix DatagramPrefix::Parse(const std::uint8_t* bytes) {
  DatagramPrefix prefix;
  std::memcpy(&prefix.frame_id, bytes, 4);
  std::memcpy(&prefix.packet_count, bytes + 4, 2);
  std::memcpy(&prefix.packet_index, bytes + 6, 2);
  return prefix;
}

DatagramPrefix EncodedFrame::Prefix(int k) const {
  TAC3D_DEMAND(k >= 0 && k <= packet_count());
  return {frame_id, static_cast<std::uint16_t>(packet_count()), static_cast<std::uint16_t>(k)};
}

std::string_view EncodedFrame::Payload(int k) const {
  TAC3D_DEMAND(k >= 0 && k <= packet_count());
  if (k == 0) return header;
  return std::string_view(body).substr((k - 1) * kChunkBytes, kChunkBytes);
}

std::vector<std::string> EncodedFrame::Datagrams() const {
  std::vector<std::string> datagrams;
  for (int k = 0; k <= packet_count(); ++k) {
    const auto prefix = Prefix(k).Bytes();
    std::string datagram(prefix.begin(), prefix.end());
    datagram += Payload(k);
    datagrams.push_back(std::move(datagram));
  }
  return datagrams;
}

void EncodeFrame(const TactileFrame& frame,
                 std::uint32_t frame_id,
                 const cv::Mat& image,
                 ExtraItems extras,
                 EncodedFrame* out) {
  frame.Validate();
  CheckSn(frame.sn);
  out->frame_id = frame_id;
  out->header.clear();
  out->body.clear();
  fmt::format_to(std::back_inserter(out->header),
                 "SN: \"{}\"\nindex: {}\ntimestamp: {}\nmsg: \"{}\"\ndata:\n",
                 frame.sn,
                 frame.index,
                 YamlFloat(frame.timestamp_s),
                 FrameFlagNames(frame.flags));
  AppendVendorItems(frame, out);
  AppendExtraItems(frame, extras, out);
  if (!image.empty()) AppendImage(image, out);
  if (out->header.size() > kChunkBytes) {
    throw Error(
        fmt::format("Tac3D encoder: the text header is {} bytes; it must fit in one "
                    "datagram ({} bytes): shorten the SN",
                    out->header.size(),
                    kChunkBytes));
  }
  if (out->packet_count() > 0xffff) {
    throw Error(fmt::format("Tac3D encoder: a {}-byte body needs {} datagrams, at most 65535",
                            out->body.size(),
                            out->packet_count()));
  }
}

const DecodedField* DecodedFrame::Find(std::string_view name) const {
  const auto it = fields.find(name);
  return it == fields.end() ? nullptr : &it->second;
}

DecodedFrame DecodeFrame(std::string_view header, std::string_view body) {
  YAML::Node root;
  DecodedFrame frame;
  try {
    root = YAML::Load(std::string(header));
    if (!root.IsMap()) throw DecodeError(DropReason::kBadHeader, "the text header is not a map");
    frame.sn = root["SN"].as<std::string>();
    frame.index = root["index"].as<std::int64_t>();
    frame.timestamp_s = root["timestamp"].as<double>();
    if (const YAML::Node msg = root["msg"]; msg && !msg.IsNull()) frame.msg = msg.as<std::string>();
    if (!root["data"].IsSequence()) {
      throw DecodeError(DropReason::kBadHeader, "the text header's 'data' is not a list");
    }
  } catch (const YAML::Exception& e) {
    throw DecodeError(DropReason::kBadHeader,
                      fmt::format("the text header does not parse as SN, index, timestamp, "
                                  "data: {}",
                                  e.what()));
  }
  const YAML::Node data = root["data"];
  for (std::size_t k = 0; k < data.size(); ++k) {
    const YAML::Node item = data[k];
    std::string name = fmt::format("#{}", k);
    try {
      if (!item.IsMap()) {
        throw DecodeError(DropReason::kBadField, fmt::format("data item {} is not a map", k));
      }
      name = item["name"].as<std::string>();
      if (frame.fields.contains(name)) {
        throw DecodeError(DropReason::kBadField, fmt::format("item '{}' appears twice", name));
      }
      frame.fields.emplace(name, DecodeItem(item, name, body));
    } catch (const YAML::Exception& e) {
      throw DecodeError(DropReason::kBadField, fmt::format("item '{}': {}", name, e.what()));
    }
  }
  CheckTableShapes(frame);
  frame.slip = DecodeSlip(frame);
  return frame;
}

}  // namespace tac3d
