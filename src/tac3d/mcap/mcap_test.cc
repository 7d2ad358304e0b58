#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/mcap/mcap_writer.h"
#include "tac3d/mcap/recording_mcap.h"
#include "tac3d/mcap/ros2_messages.h"
#include "tac3d/record/recording.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

std::vector<std::uint8_t> Hex(const std::string& hex) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(std::stoi(hex.substr(i, 2), nullptr, 16));
  return bytes;
}

const RosHeader kHeader{1, 500'000'000, "f"};

// The goldens were written by an independent CDR encoder (Python struct) from the layout rules:
// header 00 01 00 00, alignment counted after it, strings with their NUL counted.
TEST(Ros2Cdr, WrenchStampedGolden) {
  EXPECT_EQ(CdrWrenchStamped(kHeader, {1, 2, 3}, {0.5, -0.25, 0.125}),
            Hex("00010000010000000065cd1d0200000066000000000000000000f03f00000000"
                "000000400000000000000840000000000000e03f000000000000d0bf00000000"
                "0000c03f"));
}

TEST(Ros2Cdr, CompressedImageGolden) {
  EXPECT_EQ(CdrCompressedImage(kHeader, "png", {1, 2, 3}),
            Hex("00010000010000000065cd1d020000006600000004000000706e670003000000"
                "010203"));
}

TEST(Ros2Cdr, DiagnosticArrayGolden) {
  EXPECT_EQ(CdrDiagnosticArray(kHeader, {{1, "n", "m", "h", {{"k", "v"}}}}),
            Hex("00010000010000000065cd1d0200000066000000010000000100000002000000"
                "6e000000020000006d000000020000006800000001000000020000006b000000"
                "020000007600"));
}

TEST(Ros2Cdr, MarkerCloudGolden) {
  TactileFrame frame = TactileFrame::Sized(1, 1);
  frame.positions_mm[0] = {1, 2, 3};
  frame.displacements_mm[0] = {0.5, 0, -0.25};
  frame.forces_n[0] = {0, 0, -1.5};
  frame.contact[0] = true;
  frame.slip.state = SlipState::kStick;
  EXPECT_EQ(CdrMarkerCloud(kHeader, frame),
            Hex("00010000010000000065cd1d020000006600000001000000010000000c000000"
                "0200000078000000000000000700000001000000020000007900000004000000"
                "0700000001000000020000007a00000008000000070000000100000003000000"
                "647800000c000000070000000100000003000000647900001000000007000000"
                "0100000003000000647a00001400000007000000010000000300000066780000"
                "18000000070000000100000003000000667900001c0000000700000001000000"
                "03000000667a00002000000007000000010000000600000076616c6964000000"
                "24000000020000000100000008000000636f6e74616374002500000002000000"
                "010000000b000000736c69705f73746174650000260000000200000001000000"
                "000000002800000028000000280000006f12833a6f12033ba69b443b6f12033a"
                "000000006f1283b900000000000000000000c0bf0101020001"));
}

TEST(Ros2Cdr, HeaderStampSplitsNanoseconds) {
  const RosHeader h = RosHeaderAt(12'345'678'901, "x");
  EXPECT_EQ(h.sec, 12);
  EXPECT_EQ(h.nanosec, 345'678'901u);
}

TEST(Ros2Schema, DependenciesFollowAfterSeparators) {
  const std::string bar = "\n" + std::string(80, '=') + "\n";
  EXPECT_EQ(WrenchStampedSchema().name, "geometry_msgs/msg/WrenchStamped");
  EXPECT_EQ(WrenchStampedSchema().text,
            "std_msgs/Header header\nWrench wrench\n" + bar + "MSG: std_msgs/Header\n" +
                "builtin_interfaces/Time stamp\nstring frame_id\n" + bar + "MSG: builtin_interfaces/Time\n" +
                "int32 sec\nuint32 nanosec\n" + bar + "MSG: geometry_msgs/Wrench\nVector3 force\nVector3 torque\n" +
                bar + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n");
}

TEST(RecordingMcap, RosNames) {
  EXPECT_EQ(RosNameOfSerialNumber("AD2-0065L"), "AD2_0065L");
  EXPECT_EQ(RosNameOfSerialNumber("0065 L"), "sn_0065_L");
  EXPECT_EQ(McapTopicNamespace("TAC3D-TWIN"), "/tac3d/TAC3D_TWIN");
}

// A reader written from the specification, independent of the writer.
struct Cursor {
  const std::vector<std::uint8_t>& b;
  std::size_t at;
  template <typename T>
  T Get() {
    T v;
    EXPECT_LE(at + sizeof(T), b.size());
    std::memcpy(&v, b.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  std::string String() {
    const auto n = Get<std::uint32_t>();
    std::string s(b.begin() + at, b.begin() + at + n);
    at += n;
    return s;
  }
};

struct Record {
  std::uint8_t op;
  std::size_t content;  // offset of the content
  std::uint64_t length;
};

Record RecordAt(const std::vector<std::uint8_t>& b, std::size_t at) {
  Cursor c{b, at};
  const auto op = c.Get<std::uint8_t>();
  const auto length = c.Get<std::uint64_t>();
  return {op, c.at, length};
}

// CDR reading of what the tests check: the header's stamp and frame_id, then the rest.
struct CdrReader {
  const std::uint8_t* p;
  std::size_t at = 4;
  template <typename T>
  T Get() {
    while ((at - 4) % sizeof(T) != 0) ++at;
    T v;
    std::memcpy(&v, p + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  std::string String() {
    const auto n = Get<std::uint32_t>();
    std::string s(reinterpret_cast<const char*>(p + at), n - 1);
    at += n;
    return s;
  }
};

class McapFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tac3d::testing::MakeTempDir("mcap_file");
    for (int i = 0; i < kFrames; ++i) {
      frames_.push_back(MakeSyntheticTactileFrame("AD2-0065L", i, 3, 4));
      frames_.back().slip.state = SlipState::kStick;
      // 0.4 s apart, so the status goes out at frames 0, 3, 6.
      frames_.back().timestamp_s = 0.4 * i;
      images_.push_back(i % 2 == 0 ? cv::Mat(6, 8, CV_8UC1, cv::Scalar(i * 10)) : cv::Mat());
    }
    path_ = dir_ + "/out.mcap";
    std::size_t next = 0;
    McapExportOptions options;
    options.chunk_bytes = 2000;  // several chunks, each with its own message indexes
    result_ = ExportFramesToMcap(
        path_,
        [&]() -> std::optional<RecordedFrame> {
          if (next == frames_.size()) return std::nullopt;
          ++next;
          return RecordedFrame{frames_[next - 1], images_[next - 1]};
        },
        options);
    std::ifstream in(path_, std::ios::binary);
    bytes_.assign(std::istreambuf_iterator<char>(in), {});
  }

  static constexpr int kFrames = 8;
  std::string dir_, path_;
  std::vector<TactileFrame> frames_;
  std::vector<cv::Mat> images_;
  McapExportResult result_;
  std::vector<std::uint8_t> bytes_;
};

TEST_F(McapFileTest, StructureAndIndexesAndValues) {
  ASSERT_GT(bytes_.size(), 40u);
  EXPECT_EQ(result_.frames, kFrames);
  EXPECT_EQ(result_.images, 4);
  EXPECT_EQ(result_.topics, (std::vector<std::string>{"/tac3d/AD2_0065L/wrench", "/tac3d/AD2_0065L/markers",
                                                      "/tac3d/AD2_0065L/status", "/tac3d/AD2_0065L/image"}));
  // Magic at both ends; the header first, the footer last.
  EXPECT_EQ(0, std::memcmp(bytes_.data(), kMcapMagic, 8));
  EXPECT_EQ(0, std::memcmp(bytes_.data() + bytes_.size() - 8, kMcapMagic, 8));
  const Record header = RecordAt(bytes_, 8);
  ASSERT_EQ(header.op, 0x01);
  Cursor hc{bytes_, header.content};
  EXPECT_EQ(hc.String(), "ros2");
  const std::size_t footer_at = bytes_.size() - 8 - (1 + 8 + 20);
  const Record footer = RecordAt(bytes_, footer_at);
  ASSERT_EQ(footer.op, 0x02);
  ASSERT_EQ(footer.length, 20u);
  Cursor fc{bytes_, footer.content};
  const auto summary_start = fc.Get<std::uint64_t>();
  const auto offsets_start = fc.Get<std::uint64_t>();
  const auto summary_crc = fc.Get<std::uint32_t>();
  EXPECT_EQ(summary_crc, Crc32(0, bytes_.data() + summary_start, footer_at + 1 + 8 + 16 - summary_start));

  // The data section: chunks, each followed by message indexes, then the data end at summary_start.
  std::size_t at = header.content + header.length;
  std::vector<std::size_t> chunks;
  for (;;) {
    const Record r = RecordAt(bytes_, at);
    ASSERT_TRUE(r.op == 0x06 || r.op == 0x07 || r.op == 0x0F) << int(r.op);
    if (r.op == 0x06) chunks.push_back(at);
    at = r.content + r.length;
    if (r.op == 0x0F) break;
  }
  EXPECT_EQ(at, summary_start);
  EXPECT_GE(chunks.size(), 3u);

  // The summary offsets name each group; collect channels, statistics and chunk indexes.
  std::map<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>> groups;
  for (at = offsets_start; at < footer_at;) {
    const Record r = RecordAt(bytes_, at);
    ASSERT_EQ(r.op, 0x0E);
    Cursor c{bytes_, r.content};
    const auto op = c.Get<std::uint8_t>();
    const auto start = c.Get<std::uint64_t>();
    groups[op] = {start, c.Get<std::uint64_t>()};
    at = r.content + r.length;
  }
  std::set<int> ops;
  for (const auto& [op, group] : groups) ops.insert(op);
  ASSERT_EQ(ops, (std::set<int>{0x03, 0x04, 0x08, 0x0B}));  // schemas, channels, chunk indexes, statistics
  EXPECT_EQ(groups[0x03].first, summary_start);
  std::map<std::uint16_t, std::string> topics;
  std::map<std::uint16_t, std::string> schema_names;
  std::uint64_t stat_messages = 0;
  std::vector<std::size_t> indexed_chunks;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::vector<std::uint8_t>>>> messages;
  for (const auto& [op, group] : groups) {
    for (at = group.first; at < group.first + group.second;) {
      const Record r = RecordAt(bytes_, at);
      ASSERT_EQ(r.op, op);
      Cursor c{bytes_, r.content};
      if (op == 0x03) {
        const auto id = c.Get<std::uint16_t>();
        schema_names[id] = c.String();
        EXPECT_EQ(c.String(), "ros2msg");
      } else if (op == 0x04) {
        const auto id = c.Get<std::uint16_t>();
        const auto schema = c.Get<std::uint16_t>();
        topics[id] = c.String();
        EXPECT_EQ(c.String(), "cdr");
        EXPECT_TRUE(schema_names.count(schema)) << schema;
      } else if (op == 0x0B) {
        stat_messages = c.Get<std::uint64_t>();
      } else if (op == 0x08) {
        c.Get<std::uint64_t>();
        c.Get<std::uint64_t>();
        const auto chunk_offset = c.Get<std::uint64_t>();
        const auto chunk_length = c.Get<std::uint64_t>();
        indexed_chunks.push_back(chunk_offset);
        const Record chunk = RecordAt(bytes_, chunk_offset);
        ASSERT_EQ(chunk.op, 0x06);
        EXPECT_EQ(chunk_length, 9 + chunk.length);
        Cursor cc{bytes_, chunk.content + 16};
        const auto uncompressed = cc.Get<std::uint64_t>();
        const auto crc = cc.Get<std::uint32_t>();
        EXPECT_EQ(cc.String(), "");
        EXPECT_EQ(cc.Get<std::uint64_t>(), uncompressed);
        const std::size_t records = cc.at;
        EXPECT_EQ(crc, Crc32(0, bytes_.data() + records, uncompressed));
        // Every message index entry points at a message of its channel in the chunk's records.
        const auto map_bytes = c.Get<std::uint32_t>();
        for (std::uint32_t k = 0; k < map_bytes / 10; ++k) {
          const auto channel = c.Get<std::uint16_t>();
          const Record index = RecordAt(bytes_, c.Get<std::uint64_t>());
          ASSERT_EQ(index.op, 0x07);
          Cursor ic{bytes_, index.content};
          EXPECT_EQ(ic.Get<std::uint16_t>(), channel);
          const auto entries = ic.Get<std::uint32_t>() / 16;
          for (std::uint32_t e = 0; e < entries; ++e) {
            const auto time = ic.Get<std::uint64_t>();
            const auto offset = ic.Get<std::uint64_t>();
            const Record m = RecordAt(bytes_, records + offset);
            ASSERT_EQ(m.op, 0x05);
            Cursor mc{bytes_, m.content};
            EXPECT_EQ(mc.Get<std::uint16_t>(), channel);
            mc.Get<std::uint32_t>();
            EXPECT_EQ(mc.Get<std::uint64_t>(), time);
            EXPECT_EQ(mc.Get<std::uint64_t>(), time);
            messages[channel].emplace_back(
                time, std::vector<std::uint8_t>(bytes_.begin() + mc.at, bytes_.begin() + m.content + m.length));
          }
        }
      }
      at = r.content + r.length;
    }
  }
  EXPECT_EQ(indexed_chunks, chunks);
  ASSERT_EQ(topics.size(), 4u);
  std::uint64_t total = 0;
  for (const auto& [channel, list] : messages) total += list.size();
  EXPECT_EQ(total, stat_messages);
  EXPECT_EQ(total, result_.messages);

  // Every message's values are the frame's, in SI units, stamped with its timestamp.
  for (const auto& [channel, list] : messages) {
    const std::string& topic = topics[channel];
    std::vector<int> frames_seen;
    for (const auto& [time, data] : list) {
      const int i = static_cast<int>(std::llround(time / 4e8));
      ASSERT_LT(i, kFrames);
      frames_seen.push_back(i);
      const TactileFrame& f = frames_[i];
      CdrReader r{data.data()};
      EXPECT_EQ(0, std::memcmp(data.data(), "\x00\x01\x00\x00", 4));
      const auto sec = r.Get<std::int32_t>();
      const auto nanosec = r.Get<std::uint32_t>();
      EXPECT_EQ(sec * 1'000'000'000ull + nanosec, time);
      EXPECT_EQ(r.String(), "tac3d_AD2_0065L");
      if (topic.ends_with("/wrench")) {
        for (int k = 0; k < 3; ++k) EXPECT_EQ(r.Get<double>(), f.resultant_force_n[k]);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(r.Get<double>(), f.resultant_moment_nmm[k] / 1000);
      } else if (topic.ends_with("/markers")) {
        EXPECT_EQ(r.Get<std::uint32_t>(), 3u);
        EXPECT_EQ(r.Get<std::uint32_t>(), 4u);
        const auto fields = r.Get<std::uint32_t>();
        for (std::uint32_t k = 0; k < fields; ++k) {
          r.String();
          r.Get<std::uint32_t>();
          r.Get<std::uint8_t>();
          r.Get<std::uint32_t>();
        }
        r.Get<std::uint8_t>();
        EXPECT_EQ(r.Get<std::uint32_t>(), 40u);
        EXPECT_EQ(r.Get<std::uint32_t>(), 160u);
        ASSERT_EQ(r.Get<std::uint32_t>(), 12u * 40);
        for (int m = 0; m < 12; ++m) {
          const std::uint8_t* p = data.data() + r.at + 40 * m;
          float v[9];
          std::memcpy(v, p, sizeof v);
          for (int k = 0; k < 3; ++k) {
            if (f.valid[m]) {
              EXPECT_EQ(v[k], static_cast<float>(f.positions_mm[m][k] / 1000));
              EXPECT_EQ(v[3 + k], static_cast<float>(f.displacements_mm[m][k] / 1000));
            }
            EXPECT_EQ(v[6 + k], static_cast<float>(f.forces_n[m][k]));
          }
          EXPECT_EQ(p[36], f.valid[m] ? 1 : 0);
          EXPECT_EQ(p[37], f.contact[m] ? 1 : 0);
          EXPECT_EQ(p[38], 2);
        }
      } else if (topic.ends_with("/image")) {
        EXPECT_EQ(r.String(), "png");
        const auto n = r.Get<std::uint32_t>();
        const cv::Mat decoded =
            cv::imdecode(std::vector<std::uint8_t>(data.begin() + r.at, data.begin() + r.at + n), cv::IMREAD_UNCHANGED);
        ASSERT_FALSE(images_[i].empty());
        EXPECT_EQ(cv::norm(decoded, images_[i], cv::NORM_INF), 0.0);
      } else {
        ASSERT_TRUE(topic.ends_with("/status")) << topic;
        EXPECT_EQ(r.Get<std::uint32_t>(), 1u);
        EXPECT_EQ(r.Get<std::uint8_t>(), f.flags == 0 ? 0 : 1);
        EXPECT_EQ(r.String(), "tac3d AD2-0065L");
      }
    }
    if (topic.ends_with("/status")) {
      EXPECT_EQ(frames_seen, (std::vector<int>{0, 3, 6}));
    } else if (topic.ends_with("/image")) {
      EXPECT_EQ(frames_seen, (std::vector<int>{0, 2, 4, 6}));
    } else {
      EXPECT_EQ(frames_seen.size(), static_cast<std::size_t>(kFrames));
    }
  }
}

TEST_F(McapFileTest, RefusesAnExistingFileUnlessOverwrite) {
  const auto one = [done = false]() mutable -> std::optional<RecordedFrame> {
    if (std::exchange(done, true)) return std::nullopt;
    return RecordedFrame{MakeSyntheticTactileFrame("X", 0, 2, 2), {}};
  };
  EXPECT_THROW(ExportFramesToMcap(path_, one), Error);
  McapExportOptions options;
  options.overwrite = true;
  EXPECT_EQ(ExportFramesToMcap(path_, one, options).frames, 1);
}

}  // namespace
}  // namespace tac3d
