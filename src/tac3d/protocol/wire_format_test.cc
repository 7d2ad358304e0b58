#include "tac3d/protocol/wire_format.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/protocol/frame_assembler.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

// The vendor's six items in its order (its processing program's sensor.yaml), then tac3d's
// extra ones, written out independently of the encoder's constants.
struct ExpectedItem {
  std::string name, type;
  int height, width;  // mat only
  std::size_t length;
};
const std::vector<ExpectedItem> kVendorTable = {
    {"3D_Displacements", "mat", 400, 3, 9600},
    {"3D_Positions", "mat", 400, 3, 9600},
    {"3D_Forces", "mat", 400, 3, 9600},
    {"3D_ResultantForce", "mat", 1, 3, 24},
    {"3D_ResultantMoment", "mat", 1, 3, 24},
    {"InitializeProgress", "f64", 0, 0, 8},
};
const std::vector<ExpectedItem> kExtraTable = {
    {"3D_Normals", "mat", 400, 3, 9600},
    {"SlipState", "i32", 0, 0, 4},
    {"SlipFraction", "f64", 0, 0, 8},
    {"Friction", "f64", 0, 0, 8},
    {"FrictionSigma", "f64", 0, 0, 8},
    {"SlipMargin", "mat", 1, 3, 24},
};

std::vector<ExpectedItem> FullTable() {
  std::vector<ExpectedItem> table = kVendorTable;
  table.insert(table.end(), kExtraTable.begin(), kExtraTable.end());
  return table;
}

const ExtraItems kAllExtras = ExtraItems().set();

EncodedFrame Encode(const TactileFrame& frame,
                    const cv::Mat& image = cv::Mat(),
                    ExtraItems extras = kAllExtras) {
  EncodedFrame encoded;
  EncodeFrame(frame, 0xA1B2C3D4, image, extras, &encoded);
  return encoded;
}

// The data items' names, in the header's order.
std::vector<std::string> ItemNames(const EncodedFrame& encoded) {
  std::vector<std::string> names;
  for (const YAML::Node& item : YAML::Load(encoded.header)["data"]) {
    names.push_back(item["name"].as<std::string>());
  }
  return names;
}

std::optional<ReceivedFrame> Reassemble(const std::vector<std::string>& datagrams,
                                        FrameAssembler* assembler) {
  std::optional<ReceivedFrame> out;
  for (const auto& d : datagrams) {
    auto frame =
        assembler->Push({0x7f000001, 5000},
                        std::span(reinterpret_cast<const std::uint8_t*>(d.data()), d.size()),
                        0.0);
    if (frame) out = std::move(frame);
  }
  return out;
}

RowMajorMatrixXd AsMatrix(const std::vector<Eigen::Vector3d>& v) {
  RowMajorMatrixXd m(v.size(), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.row(i) = v[i].transpose();
  return m;
}

// The header's items against `table`, and the body they point into.
void ExpectItems(const YAML::Node& data, const std::vector<ExpectedItem>& table) {
  ASSERT_EQ(data.size(), table.size());
  for (std::size_t k = 0; k < table.size(); ++k) {
    SCOPED_TRACE(table[k].name);
    EXPECT_EQ(data[k]["name"].as<std::string>(), table[k].name);
    EXPECT_EQ(data[k]["type"].as<std::string>(), table[k].type);
    EXPECT_EQ(data[k]["length"].as<std::size_t>(), table[k].length);
    if (table[k].type == "mat") {
      EXPECT_EQ(data[k]["dtype"].as<std::string>(), "f64");
      EXPECT_EQ(data[k]["height"].as<int>(), table[k].height);
      EXPECT_EQ(data[k]["width"].as<int>(), table[k].width);
    }
  }
}

// Item `name`'s float64 number i, read straight from the body at the header's offset, as a
// vendor client does.
double F64At(const YAML::Node& data, const std::string& body, const char* name, int i) {
  for (const auto& item : data) {
    if (item["name"].as<std::string>() != name) continue;
    double v;
    std::memcpy(&v, body.data() + item["offset"].as<std::size_t>() + 8 * i, 8);
    return v;
  }
  ADD_FAILURE() << name << " missing";
  return 0.0;
}

TEST(WireFormat, DatagramsFollowTheProtocolByteForByte) {
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 42);
  const auto datagrams = Encode(frame, cv::Mat(), ExtraItems()).Datagrams();
  // 28800 bytes of markers + 48 of resultants + 8 of progress = 28856: 21 chunks.
  ASSERT_EQ(datagrams.size(), 22u);
  std::string body;
  for (std::size_t k = 0; k < datagrams.size(); ++k) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(datagrams[k].data());
    ASSERT_LE(datagrams[k].size(), 1400u);
    EXPECT_EQ(p[0] | p[1] << 8 | p[2] << 16 | std::uint32_t{p[3]} << 24, 0xA1B2C3D4u);
    EXPECT_EQ(p[4] | p[5] << 8, 21);
    EXPECT_EQ(p[6] | p[7] << 8, static_cast<int>(k));
    if (k >= 1 && k < 21) {
      EXPECT_EQ(datagrams[k].size(), 1400u) << "chunk " << k;
    }
    if (k >= 1) body += datagrams[k].substr(8);
  }
  EXPECT_EQ(body.size(), 28856u);

  const YAML::Node header = YAML::Load(datagrams[0].substr(8));
  EXPECT_EQ(header["SN"].as<std::string>(), "AD2-0065L");
  EXPECT_EQ(header["index"].as<int>(), 42);
  EXPECT_EQ(header["timestamp"].as<double>(), frame.timestamp_s);
  EXPECT_EQ(header["msg"].as<std::string>(), "markers_lost");
  const YAML::Node data = header["data"];
  ExpectItems(data, kVendorTable);
  EXPECT_EQ(F64At(data, body, "3D_Positions", 3 * 21 + 2), frame.positions_mm[21].z());
  EXPECT_EQ(F64At(data, body, "3D_Displacements", 3 * 399), frame.displacements_mm[399].x());
  EXPECT_EQ(F64At(data, body, "3D_Forces", 3 * 210 + 1), frame.forces_n[210].y());
  EXPECT_EQ(F64At(data, body, "3D_ResultantForce", 2), frame.resultant_force_n.z());
  EXPECT_EQ(F64At(data, body, "3D_ResultantMoment", 1), frame.resultant_moment_nmm.y());
  // The 8 bytes of a double 100.0, what the vendor's C++ client compares with 100.0.
  EXPECT_EQ(F64At(data, body, "InitializeProgress", 0), 100.0);
}

TEST(WireFormat, ExtraItemsFollowTheVendorsSixWhenAsked) {
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 42);
  const EncodedFrame all = Encode(frame);
  // + 9600 of normals, 4 of slip state, 48 of slip figures = 38508: 28 chunks.
  EXPECT_EQ(all.body.size(), 38508u);
  EXPECT_EQ(all.packet_count(), 28);
  const YAML::Node data = YAML::Load(all.header)["data"];
  ExpectItems(data, FullTable());
  EXPECT_EQ(F64At(data, all.body, "3D_Normals", 3 * 5), frame.normals[5].x());
  EXPECT_EQ(F64At(data, all.body, "SlipFraction", 0), frame.slip.fraction);  // frame 42: 0.42
  // A subset keeps the fixed order, whatever the order asked.
  const ExtraItems some = ParseExtraItems("FrictionSigma,3D_Normals", "test");
  const std::vector<std::string> names = ItemNames(Encode(frame, cv::Mat(), some));
  EXPECT_EQ(names, (std::vector<std::string>{"3D_Displacements", "3D_Positions", "3D_Forces",
                                             "3D_ResultantForce", "3D_ResultantMoment",
                                             "InitializeProgress", "3D_Normals",
                                             "FrictionSigma"}));
}

TEST(WireFormat, ExtraItemsAreParsedByNameOrAll) {
  EXPECT_EQ(ParseExtraItems("", "--udp-items"), ExtraItems());
  EXPECT_EQ(ParseExtraItems("all", "--udp-items"), kAllExtras);
  EXPECT_EQ(ParseExtraItems("3D_Normals,SlipState,SlipFraction,Friction,FrictionSigma,SlipMargin",
                            "x"),
            kAllExtras);
  EXPECT_EQ(ParseExtraItems("SlipState", "x"),
            ExtraItems().set(static_cast<int>(ExtraItem::kSlipState)));
  for (int k = 0; k < kNumExtraItems; ++k) {
    const char* name = ExtraItemName(static_cast<ExtraItem>(k));
    EXPECT_EQ(ParseExtraItems(name, "x"), ExtraItems().set(k)) << name;
  }
  EXPECT_THAT([] { ParseExtraItems("3D_Normals,Slip", "--udp-items"); },
              ::testing::ThrowsMessage<Error>(::testing::StrEq(
                  "--udp-items '3D_Normals,Slip': unknown item 'Slip'; the items to add to the "
                  "vendor's six are 3D_Normals, SlipState, SlipFraction, Friction, FrictionSigma, "
                  "SlipMargin (or all)")));
  EXPECT_THAT([] { ParseExtraItems("3D_Forces", "--udp-items"); },
              ::testing::ThrowsMessage<Error>(HasSubstr(
                  "--udp-items '3D_Forces': '3D_Forces' is one of the vendor's six, always sent")));
  EXPECT_THROW(ParseExtraItems("3D_Normals,", "x"), Error);  // an empty name
  EXPECT_THROW(ParseExtraItems(" SlipState", "x"), Error);
}

TEST(WireFormat, RoundTripThroughTheClientDecoderIsExact) {
  TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 7);
  frame.initialize_progress = 63;
  FrameAssembler assembler;
  const auto received = Reassemble(Encode(frame).Datagrams(), &assembler);
  ASSERT_TRUE(received) << assembler.last_error() << " " << assembler.drops().ToString();
  const DecodedFrame& decoded = received->frame;
  EXPECT_EQ(decoded.sn, frame.sn);
  EXPECT_EQ(decoded.index, frame.index);
  EXPECT_EQ(decoded.timestamp_s, frame.timestamp_s);
  EXPECT_EQ(decoded.msg, "markers_lost");
  ASSERT_EQ(decoded.fields.size(), FullTable().size());
  for (const auto& item : FullTable()) {
    const DecodedField* field = decoded.Find(item.name);
    ASSERT_NE(field, nullptr) << item.name;
    if (item.type == "mat") {
      EXPECT_EQ(field->type, FieldType::kMat);
      EXPECT_EQ(field->matrix.rows(), item.height) << item.name;
      EXPECT_EQ(field->matrix.cols(), item.width) << item.name;
    }
  }
  EXPECT_TRUE(decoded.Find("3D_Positions")->matrix == AsMatrix(frame.positions_mm));
  EXPECT_TRUE(decoded.Find("3D_Displacements")->matrix == AsMatrix(frame.displacements_mm));
  EXPECT_TRUE(decoded.Find("3D_Forces")->matrix == AsMatrix(frame.forces_n));
  EXPECT_TRUE(decoded.Find("3D_Normals")->matrix == AsMatrix(frame.normals));
  EXPECT_TRUE(decoded.Find("3D_ResultantForce")->matrix == frame.resultant_force_n.transpose());
  EXPECT_TRUE(decoded.Find("3D_ResultantMoment")->matrix == frame.resultant_moment_nmm.transpose());
  const DecodedField* progress = decoded.Find("InitializeProgress");
  EXPECT_EQ(progress->type, FieldType::kF64);
  EXPECT_EQ(progress->matrix(0, 0), 63.0);
  EXPECT_EQ(decoded.slip, frame.slip);
  EXPECT_EQ(decoded.slip.state, SlipState::kStick);  // frame 7
  EXPECT_EQ(assembler.drops().total(), 0);
}

TEST(WireFormat, WithoutTheExtraItemsTheClientDecodesNoNormalsAndAnUnknownSlip) {
  FrameAssembler assembler;
  const auto received = Reassemble(
      Encode(MakeSyntheticTactileFrame("AD2-0065L", 7), cv::Mat(), ExtraItems()).Datagrams(),
      &assembler);
  ASSERT_TRUE(received) << assembler.last_error();
  EXPECT_EQ(received->frame.fields.size(), kVendorTable.size());
  EXPECT_EQ(received->frame.Find("3D_Normals"), nullptr);
  EXPECT_EQ(received->frame.slip.state, SlipState::kUnknown);
  EXPECT_TRUE(std::isnan(received->frame.slip.fraction));
}

TEST(WireFormat, SlipExtraItemsRoundTripInEveryState) {
  for (int index = 0; index < kNumSlipStates; ++index) {
    const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", index + 100);
    FrameAssembler assembler;
    const auto received = Reassemble(Encode(frame).Datagrams(), &assembler);
    ASSERT_TRUE(received) << assembler.last_error();
    EXPECT_EQ(received->frame.slip, frame.slip) << index;
    EXPECT_EQ(received->frame.slip.state, static_cast<SlipState>(index));
  }
  // Gross slip carries a friction coefficient and its sigma, bit for bit.
  const TactileFrame gross = MakeSyntheticTactileFrame("AD2-0065L", 104);
  ASSERT_EQ(gross.slip.state, SlipState::kGrossSlip);
  FrameAssembler assembler;
  const auto received = Reassemble(Encode(gross).Datagrams(), &assembler);
  ASSERT_TRUE(received);
  EXPECT_EQ(received->frame.Find("Friction")->matrix(0, 0), gross.slip.friction);
  EXPECT_EQ(received->frame.slip.friction_sigma, gross.slip.friction_sigma);
  EXPECT_EQ(received->frame.Find("SlipMargin")->matrix(0, 2), gross.slip.least_normal_force_n);
  // Partial slip carries them too, with its margin to gross slip.
  const TactileFrame partial = MakeSyntheticTactileFrame("AD2-0065L", 103);
  ASSERT_EQ(partial.slip.state, SlipState::kPartialSlip);
  const auto received_partial = Reassemble(Encode(partial).Datagrams(), &assembler);
  ASSERT_TRUE(received_partial);
  EXPECT_EQ(received_partial->frame.Find("SlipMargin")->matrix(0, 0), partial.slip.margin);
  EXPECT_EQ(received_partial->frame.slip.margin_sigma, partial.slip.margin_sigma);
  EXPECT_EQ(received_partial->frame.slip.least_normal_force_n, partial.slip.least_normal_force_n);
  EXPECT_GT(partial.slip.margin, 0.0);
}

// The header must fit in one datagram. With every extra item: `tac3d run`'s stream (no image)
// with every flag and a 48-character SN; a stream with images, a 16-character SN and the four
// per-frame measurement flags. Every flag, an image and every extra item do not fit together
// (the encoder throws, naming the header's size).
TEST(WireFormat, HeaderWithTheExtraItemsStillFitsWithEveryFlagAndALongSn) {
  TactileFrame frame = MakeSyntheticTactileFrame(std::string(48, 'S'), 123456789);
  for (const FrameFlag flag : kAllFrameFlags) frame.set(flag);
  EncodedFrame out;
  EncodeFrame(frame, 0, cv::Mat(), kAllExtras, &out);
  EXPECT_LE(out.header.size(), kChunkBytes);
  TactileFrame imaged = MakeSyntheticTactileFrame(std::string(16, 'S'), 123456789);
  for (const FrameFlag flag : {FrameFlag::kMarkersLost,
                               FrameFlag::kGridReacquired,
                               FrameFlag::kDisplacementOutOfRange,
                               FrameFlag::kForceOutOfRange}) {
    imaged.set(flag);
  }
  const cv::Mat image(2, 2, CV_8UC1, cv::Scalar(7));
  EncodedFrame with_image;
  EncodeFrame(imaged, 0, image, kAllExtras, &with_image);
  EXPECT_LE(with_image.header.size(), kChunkBytes);
  const std::size_t with_image_bytes = with_image.header.size();
  for (const FrameFlag flag : kAllFrameFlags) imaged.set(flag);
  EXPECT_THAT([&] { EncodeFrame(imaged, 0, image, kAllExtras, &with_image); },
              ::testing::ThrowsMessage<Error>(HasSubstr("it must fit in one")));
  EncodedFrame plain, six;
  EncodeFrame(MakeSyntheticTactileFrame("AD2-0065L", 42), 0, cv::Mat(), kAllExtras, &plain);
  EncodeFrame(MakeSyntheticTactileFrame("AD2-0065L", 42), 0, cv::Mat(), ExtraItems(), &six);
  std::printf("header: %zu bytes for docs/protocol.md's example (%zu with the extra items), %zu "
              "with them, a 48-byte SN and every flag, %zu with them, a 16-byte SN, four flags "
              "and an image\n",
              six.header.size(), plain.header.size(), out.header.size(),
              with_image_bytes);
}

TEST(WireFormat, ImageTravelsAsLosslessPng) {
  const TactileFrame frame = MakeSyntheticTactileFrame("S1", 1);
  cv::Mat image(48, 64, CV_8UC1);
  cv::randu(image, 0, 256);
  const EncodedFrame encoded = Encode(frame, image);
  EXPECT_THAT(encoded.header, HasSubstr("name: img\n    type: img"));
  FrameAssembler assembler;
  const auto received = Reassemble(encoded.Datagrams(), &assembler);
  ASSERT_TRUE(received) << assembler.last_error();
  const DecodedField* img = received->frame.Find("img");
  ASSERT_NE(img, nullptr);
  EXPECT_EQ(img->type, FieldType::kImg);
  ASSERT_EQ(img->image.size(), image.size());
  EXPECT_EQ(cv::norm(img->image, image, cv::NORM_INF), 0.0);
}

TEST(WireFormat, TimestampsAreYamlFloatsThatRoundTrip) {
  for (const double t : {0.0, 1.0, 1e-5, 123456.789, 1.0 / 3.0}) {
    TactileFrame frame = MakeSyntheticTactileFrame("S", 0);
    frame.timestamp_s = t;
    const EncodedFrame encoded = Encode(frame);
    // A '.' in every float, so YAML 1.1 parsers (PyYAML) read a number, not a string.
    const auto line = encoded.header.substr(encoded.header.find("timestamp: "));
    EXPECT_NE(line.substr(0, line.find('\n')).find('.'), std::string::npos) << line;
    EXPECT_EQ(DecodeFrame(encoded.header, encoded.body).timestamp_s, t);
  }
}

TEST(WireFormat, EncoderRefusesWhatTheWireCannotCarry) {
  EncodedFrame out;
  TactileFrame frame = MakeSyntheticTactileFrame("AD2\"", 0);
  EXPECT_THROW(EncodeFrame(frame, 0, cv::Mat(), ExtraItems(), &out), Error);
  frame.sn = std::string(1400, 'A');
  try {
    EncodeFrame(frame, 0, cv::Mat(), ExtraItems(), &out);
    ADD_FAILURE() << "a 1400-byte SN was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("must fit in one datagram"));
  }
  frame.sn = "S";
  EXPECT_THROW(
      EncodeFrame(frame, 0, cv::Mat(4, 4, CV_16UC1, cv::Scalar(0)), ExtraItems(), &out), Error);
  frame.normals.pop_back();
  EXPECT_THROW(EncodeFrame(frame, 0, cv::Mat(), ExtraItems(), &out), Error);
}

// A header with one item, to exercise each refusal of the decoder.
std::string HeaderWith(const std::string& item) {
  return "SN: S\nindex: 1\ntimestamp: 0.5\ndata:\n" + item;
}

std::pair<DropReason, std::string> RefusalOf(const std::string& header, const std::string& body) {
  try {
    DecodeFrame(header, body);
  } catch (const DecodeError& e) {
    return {e.reason(), e.what()};
  }
  ADD_FAILURE() << "accepted:\n" << header;
  return {DropReason::kEvicted, ""};
}

DropReason ReasonOf(const std::string& header, const std::string& body) {
  return RefusalOf(header, body).first;
}

TEST(WireFormat, DecoderRefusesEachKindOfBadHeaderAndField) {
  const std::string body(48, '\0');
  const std::string mat = "  - {name: 3D_ResultantForce, type: mat, dtype: f64, ";
  // Good: a header without msg (senders before 3.3.0), flow style.
  EXPECT_NO_THROW(
      DecodeFrame(HeaderWith(mat + "width: 3, height: 1, offset: 0, length: 24}"), body));
  EXPECT_EQ(ReasonOf("{[: not yaml", body), DropReason::kBadHeader);
  EXPECT_EQ(ReasonOf("- a list", body), DropReason::kBadHeader);
  EXPECT_EQ(ReasonOf("index: 1\ntimestamp: 0.5\ndata: []", body), DropReason::kBadHeader);
  EXPECT_EQ(ReasonOf("SN: S\nindex: x\ntimestamp: 0.5\ndata: []", body), DropReason::kBadHeader);
  EXPECT_EQ(ReasonOf("SN: S\nindex: 1\ntimestamp: 0.5\ndata: 3", body), DropReason::kBadHeader);
  EXPECT_EQ(ReasonOf(HeaderWith("  - 5"), body), DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith(mat + "width: 3, height: 1, offset: 40, length: 24}"), body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith(mat + "width: 3, height: 1, offset: -8, length: 24}"), body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: 3D_ResultantForce, type: mat, dtype: f32, width: 3, "
                                "height: 1, offset: 0, length: 12}"),
                     body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith(mat + "width: 3, height: 2, offset: 0, length: 24}"), body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith(mat + "width: 6, height: 1, offset: 0, length: 48}"), body),
            DropReason::kBadField);  // consistent, but not the table's 1 x 3
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: 3D_Positions, type: mat, dtype: f64, width: 2, "
                                "height: 3, offset: 0, length: 48}"),
                     body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: 3D_Positions, type: mat, dtype: f64, width: 3, "
                                "height: 1, offset: 0, length: 24}\n"
                                "  - {name: 3D_Forces, type: mat, dtype: f64, width: 3, "
                                "height: 2, offset: 0, length: 48}"),
                     body),
            DropReason::kBadField);  // per-marker heights differ
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: p, type: i32, offset: 0, length: 8}"), body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: p, type: u8, offset: 0, length: 1}"), body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: p, type: f64, offset: 0, length: 8}\n"
                                "  - {name: p, type: f64, offset: 8, length: 8}"),
                     body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: InitializeProgress, type: mat, dtype: f64, width: 1,"
                                " height: 1, offset: 0, length: 8}"),
                     body),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: img, type: img, offset: 0, length: 48}"), body),
            DropReason::kBadImage);
  // The extra items: a header without them (a vendor sensor) decodes with the slip unknown.
  EXPECT_EQ(DecodeFrame(HeaderWith("  - {name: p, type: f64, offset: 0, length: 8}"), body)
                .slip.state,
            SlipState::kUnknown);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: SlipState, type: f64, offset: 0, length: 8}"), body),
            DropReason::kBadField);
  std::string state_7 = body;
  state_7[0] = 7;
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: SlipState, type: i32, offset: 0, length: 4}"), state_7),
            DropReason::kBadField);
  EXPECT_EQ(ReasonOf(HeaderWith("  - {name: Friction, type: i32, offset: 0, length: 4}"), body),
            DropReason::kBadField);
}

// A datagram's header with aliases that stand for 10^8 values (a fuzzer's YAML, 332
// bytes, fits in one datagram), or an alias inside the node it names: the decoder reads only
// the header's top keys and each item's map, so it refuses both at the first item, which the
// message names, instead of expanding them (a decoder that walked them would not return).
TEST(WireFormat, DecoderRefusesAliasBombsWithoutExpandingThem) {
  std::string nested = "l0: &l0 [x]\n";
  for (int level = 1; level < 9; ++level) {
    nested += fmt::format("l{0}: &l{0} [", level);
    for (int k = 0; k < 10; ++k) nested += fmt::format("{}*l{}", k ? ", " : "", level - 1);
    nested += "]\n";
  }
  const std::string body(48, '\0');
  for (const std::string& data : {nested + "data: *l8\n", std::string("data: &d [*d]\n")}) {
    const auto [reason, message] = RefusalOf("SN: S\nindex: 1\ntimestamp: 0.5\n" + data, body);
    EXPECT_EQ(reason, DropReason::kBadField) << data;
    EXPECT_EQ(message, "data item 0 is not a map") << data;
  }
  const auto [reason, message] = RefusalOf("SN: &s [*s]\nindex: 1\ntimestamp: 0.5\ndata: []\n", body);
  EXPECT_EQ(reason, DropReason::kBadHeader);
  EXPECT_THAT(message, ::testing::HasSubstr("does not parse as SN, index, timestamp, data"));
}

TEST(WireFormat, DecoderTakesInitializeProgressAsF64OrAsI32AsTac3dSentItBefore) {
  std::string body(8, '\0');
  const double hundred = 100.0;
  std::memcpy(body.data(), &hundred, 8);
  const DecodedFrame f64 = DecodeFrame(
      HeaderWith("  - {name: InitializeProgress, type: f64, offset: 0, length: 8}"), body);
  EXPECT_EQ(f64.Find("InitializeProgress")->type, FieldType::kF64);
  EXPECT_EQ(f64.Find("InitializeProgress")->matrix(0, 0), 100.0);
  const std::int32_t fifty = 50;
  std::memcpy(body.data(), &fifty, 4);
  const DecodedFrame i32 = DecodeFrame(
      HeaderWith("  - {name: InitializeProgress, type: i32, offset: 0, length: 4}"), body);
  EXPECT_EQ(i32.Find("InitializeProgress")->type, FieldType::kI32);
  EXPECT_EQ(i32.Find("InitializeProgress")->matrix(0, 0), 50.0);
}

TEST(WireFormat, DecoderRefusesAnImageThatClaimsTooManyPixels) {
  // A valid PNG signature and IHDR declaring 65535 x 65535 pixels: refused before decoding.
  std::string png("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\xff\xff\0\0\xff\xff\x08\0\0\0\0", 29);
  const auto [reason, message] =
      RefusalOf(HeaderWith("  - {name: img, type: img, offset: 0, length: 29}"), png);
  EXPECT_EQ(reason, DropReason::kBadImage);
  EXPECT_THAT(message, HasSubstr("pixels"));
  // A JPEG whose SOF0 declares 65535 x 65535.
  static constexpr char kJpeg[] = "\xff\xd8\xff\xe0\0\x04xx\xff\xc0\0\x11\x08\xff\xff\xff\xff\x01";
  const std::string jpeg(kJpeg, sizeof(kJpeg) - 1);
  ASSERT_EQ(jpeg.size(), 18u);
  EXPECT_THAT(
      RefusalOf(HeaderWith("  - {name: img, type: img, offset: 0, length: 18}"), jpeg).second,
      HasSubstr("pixels"));
}

TEST(WireFormat, CommandsAreExactlyTwoBytes) {
  auto parse = [](std::string_view s) {
    return ParseCommand(std::span(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
  };
  EXPECT_EQ(parse("$C"), SensorCommand::kZero);
  EXPECT_EQ(parse("$Q"), SensorCommand::kStop);
  EXPECT_EQ(parse("$C\n"), std::nullopt);
  EXPECT_EQ(parse("$"), std::nullopt);
  EXPECT_EQ(parse("$X"), std::nullopt);
  EXPECT_EQ(CommandBytes(SensorCommand::kZero), "$C");
  EXPECT_EQ(CommandBytes(SensorCommand::kStop), "$Q");
}

}  // namespace
}  // namespace tac3d
