#include "tac3d/protocol/frame_assembler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

const Endpoint kSensorA{0x7f000001, 4001};
const Endpoint kSensorB{0x7f000001, 4002};

std::vector<std::string> DatagramsOf(const TactileFrame& frame, std::uint32_t frame_id) {
  EncodedFrame encoded;
  EncodeFrame(frame, frame_id, cv::Mat(), ExtraItems(), &encoded);
  return encoded.Datagrams();
}

std::optional<ReceivedFrame> Push(FrameAssembler* assembler,
                                  const Endpoint& from,
                                  const std::string& d,
                                  double now_s = 0.0) {
  return assembler->Push(
      from, std::span(reinterpret_cast<const std::uint8_t*>(d.data()), d.size()), now_s);
}

std::string Prefixed(std::uint32_t id,
                     std::uint16_t count,
                     std::uint16_t index,
                     std::size_t payload) {
  const auto prefix = DatagramPrefix{id, count, index}.Bytes();
  return std::string(prefix.begin(), prefix.end()) + std::string(payload, 'x');
}

TEST(FrameAssembler, ReorderedAndDuplicatedDatagramsFromTwoSensors) {
  // Sensors A and B use the same frame_id: the key is (sender, frame_id).
  struct Sent {
    TactileFrame frame;
    Endpoint from;
    std::uint32_t id;
  };
  const std::vector<Sent> sent = {{MakeSyntheticTactileFrame("A", 10), kSensorA, 7},
                                  {MakeSyntheticTactileFrame("B", 20), kSensorB, 7},
                                  {MakeSyntheticTactileFrame("A", 11), kSensorA, 8}};
  std::vector<std::pair<Endpoint, std::string>> wire;
  std::mt19937_64 rng(testing::kRandomSeed);
  for (const auto& s : sent) {
    for (const auto& d : DatagramsOf(s.frame, s.id)) {
      wire.emplace_back(s.from, d);
      if (rng() % 3 == 0) wire.emplace_back(s.from, d);
    }
  }
  std::shuffle(wire.begin(), wire.end(), rng);

  FrameAssembler assembler;
  std::vector<DecodedFrame> out;
  for (const auto& [from, d] : wire) {
    if (auto r = Push(&assembler, from, d)) {
      EXPECT_EQ(r->sender, from);
      out.push_back(std::move(r->frame));
    }
  }
  ASSERT_EQ(out.size(), 3u) << assembler.drops().ToString() << " " << assembler.last_error();
  for (const auto& s : sent) {
    const auto it = std::find_if(out.begin(), out.end(), [&](const DecodedFrame& f) {
      return f.sn == s.frame.sn && f.index == s.frame.index;
    });
    ASSERT_NE(it, out.end()) << s.frame.sn << " " << s.frame.index;
    EXPECT_EQ(it->Find(kFieldForces)->matrix(123, 2), s.frame.forces_n[123].z());
  }
  EXPECT_GT(assembler.drops()[DropReason::kDuplicate], 0);
  for (const auto reason : {DropReason::kBadHeader, DropReason::kBadField, DropReason::kEvicted}) {
    EXPECT_EQ(assembler.drops()[reason], 0) << DropReasonName(reason);
  }
  // Duplicates arriving after their frame completed start partials that time out.
  assembler.Expire(10.0);
  EXPECT_EQ(assembler.num_in_progress(), 0);
}

TEST(FrameAssembler, IncompleteFrameIsDroppedAfterTheTimeout) {
  const auto datagrams = DatagramsOf(MakeSyntheticTactileFrame("A", 1), 5);
  FrameAssembler assembler({.timeout_s = 1.0});
  for (std::size_t k = 0; k + 1 < datagrams.size(); ++k) {
    EXPECT_FALSE(Push(&assembler, kSensorA, datagrams[k], 0.0));
  }
  assembler.Expire(0.9);
  EXPECT_EQ(assembler.num_in_progress(), 1);
  EXPECT_EQ(assembler.drops()[DropReason::kTimedOut], 0);
  // The last datagram comes too late: the frame is gone, the straggler starts a new partial.
  EXPECT_FALSE(Push(&assembler, kSensorA, datagrams.back(), 1.5));
  EXPECT_EQ(assembler.drops()[DropReason::kTimedOut], 1);
  EXPECT_EQ(assembler.num_in_progress(), 1);
  // Before the timeout the same frame completes.
  FrameAssembler patient({.timeout_s = 2.0});
  for (std::size_t k = 0; k + 1 < datagrams.size(); ++k) Push(&patient, kSensorA, datagrams[k]);
  EXPECT_TRUE(Push(&patient, kSensorA, datagrams.back(), 1.5));
}

TEST(FrameAssembler, KeepsAtMostMaxInProgressDroppingTheOldest) {
  FrameAssembler assembler({.max_in_progress = 30});
  std::vector<std::vector<std::string>> frames;
  for (std::uint32_t id = 0; id < 31; ++id) {
    frames.push_back(DatagramsOf(MakeSyntheticTactileFrame("A", id), id));
    Push(&assembler, kSensorA, frames.back()[0]);
  }
  EXPECT_EQ(assembler.num_in_progress(), 30);
  EXPECT_EQ(assembler.drops()[DropReason::kEvicted], 1);
  std::optional<ReceivedFrame> out;
  for (std::size_t k = 1; k < frames[1].size(); ++k) out = Push(&assembler, kSensorA, frames[1][k]);
  ASSERT_TRUE(out);
  EXPECT_EQ(out->frame.index, 1);
  for (std::size_t k = 1; k < frames[0].size(); ++k) {
    EXPECT_FALSE(Push(&assembler, kSensorA, frames[0][k])) << "frame 0 was evicted";
  }
}

TEST(FrameAssembler, EachMalformedDatagramIsCountedUnderItsReason) {
  FrameAssembler assembler({.max_frame_bytes = 100 * kChunkBytes});
  Push(&assembler, kSensorA, std::string(7, '\0'));
  Push(&assembler, kSensorA, Prefixed(1, 2, 1, 1393));
  Push(&assembler, kSensorA, Prefixed(1, 2, 3, 10));
  Push(&assembler, kSensorA, Prefixed(1, 101, 1, kChunkBytes));
  Push(&assembler, kSensorA, Prefixed(1, 3, 1, 1000));  // not the last chunk: must be 1392
  Push(&assembler, kSensorA, Prefixed(2, 3, 1, kChunkBytes));
  Push(&assembler, kSensorA, Prefixed(2, 4, 2, kChunkBytes));
  Push(&assembler, kSensorA, Prefixed(2, 3, 1, kChunkBytes));
  const DropCounts& drops = assembler.drops();
  EXPECT_EQ(drops[DropReason::kShortDatagram], 1);
  EXPECT_EQ(drops[DropReason::kOversizedDatagram], 1);
  EXPECT_EQ(drops[DropReason::kBadPacketIndex], 1);
  EXPECT_EQ(drops[DropReason::kFrameTooLarge], 1);
  EXPECT_EQ(drops[DropReason::kBadChunkSize], 1);
  EXPECT_EQ(drops[DropReason::kInconsistentCount], 1);
  EXPECT_EQ(drops[DropReason::kDuplicate], 1);
  EXPECT_EQ(drops.total(), 7);
  EXPECT_EQ(assembler.num_in_progress(), 1);
  EXPECT_EQ(drops.ToString(),
            "short_datagram=1 oversized_datagram=1 bad_packet_index=1 frame_too_large=1 "
            "bad_chunk_size=1 inconsistent_count=1 duplicate=1");
}

TEST(FrameAssembler, HeaderOnlyFrameCompletesAtOnce) {
  const std::string header = "SN: S\nindex: 3\ntimestamp: 0.1\nmsg: hello\ndata: []\n";
  FrameAssembler assembler;
  const auto out = Push(&assembler, kSensorA, Prefixed(9, 0, 0, 0) + header);
  ASSERT_TRUE(out);
  EXPECT_EQ(out->frame.msg, "hello");
  EXPECT_TRUE(out->frame.fields.empty());
}

TEST(FrameAssembler, BadFrameIsCountedWithItsReasonAndMessage) {
  FrameAssembler assembler;
  EXPECT_FALSE(Push(&assembler, kSensorB, Prefixed(9, 0, 0, 0) + "SN: [unclosed"));
  EXPECT_EQ(assembler.drops()[DropReason::kBadHeader], 1);
  EXPECT_THAT(assembler.last_error(), ::testing::HasSubstr("frame 9 from 127.0.0.1:4002"));
}

TEST(FrameAssemblerOptions, ValidateNamesTheField) {
  EXPECT_THROW(FrameAssembler({.timeout_s = 0.0}), Error);
  EXPECT_THROW(FrameAssembler({.max_in_progress = 0}), Error);
  try {
    FrameAssemblerOptions{.max_frame_bytes = 10}.Validate();
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("max_frame_bytes"));
  }
}

}  // namespace
}  // namespace tac3d
