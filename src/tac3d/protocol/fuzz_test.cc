// Seeded fuzzing of everything that reads the network: the client's reassembly and decoder, the
// client's socket, and the sender's command socket. Malformed input must be counted and
// ignored (no crash, leak or hang; run under -DTAC3D_SANITIZE=ON for the leak and memory
// checks) and must leave each able to take good input afterwards.
#include <gtest/gtest.h>

#include <random>
#include <thread>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/protocol/client.h"
#include "tac3d/protocol/udp_sender.h"
#include "tac3d/protocol/udp_socket.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

std::span<const std::uint8_t> Bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

std::string Prefix(std::uint32_t id, std::uint16_t count, std::uint16_t index) {
  const auto bytes = DatagramPrefix{id, count, index}.Bytes();
  return std::string(bytes.begin(), bytes.end());
}

// Makes one malformed (or, by chance, well-formed) datagram of a randomly chosen kind.
class DatagramFuzzer {
 public:
  DatagramFuzzer() : rng_(testing::kRandomSeed) {
    EncodedFrame encoded;
    EncodeFrame(
        MakeSyntheticTactileFrame("FUZZ", 1, 4, 4), 0, cv::Mat(), ExtraItems().set(), &encoded);
    genuine_ = encoded.Datagrams();
    genuine_header_ = encoded.header;
  }

  std::string Next() {
    const std::uint32_t id = Uniform(0, 40);  // few ids, so fragments collide with partials
    switch (Uniform(0, 10)) {
      case 0:  // random bytes, up to oversized
        return RandomBytes(Uniform(0, 2000));
      case 1:  // truncated prefix
        return RandomBytes(Uniform(0, 7));
      case 2:  // random prefix: bad index, huge counts
        return Prefix(id, Uniform(0, 65535), Uniform(0, 65535)) + RandomBytes(Uniform(0, 1392));
      case 3: {  // a genuine datagram with a few bytes flipped (prefix, YAML or body)
        std::string d = Genuine(id);
        for (int k = Uniform(1, 4); k > 0; --k) d[Uniform(0, d.size() - 1)] ^= Uniform(1, 255);
        return d;
      }
      case 4: {  // a genuine datagram cut short
        const std::string d = Genuine(id);
        return d.substr(0, Uniform(0, d.size()));
      }
      case 5: {  // a genuine datagram with another packet_count
        std::string d = Genuine(id);
        const std::uint16_t count = Uniform(0, genuine_.size() + 2);
        std::memcpy(d.data() + 4, &count, 2);
        return d;
      }
      case 6:  // a header of random text
        return Prefix(id, Uniform(0, 2), 0) + RandomText(Uniform(0, 1392));
      case 7:  // deeply nested YAML
        return Prefix(id, 0, 0) + std::string(Uniform(1, 1392), "[{"[Uniform(0, 1)]);
      case 8:  // well-formed YAML with wrong values: offsets, lengths, shapes, dtypes, types
        return Prefix(id, 0, 0) + WrongHeader();
      case 9: {  // the genuine header with the body cut (body shorter than offset + length)
        const std::uint16_t count = Uniform(0, genuine_.size() - 2);
        return Prefix(id, count, 0) + genuine_header_;
      }
      default: {  // a body chunk for such a frame
        return Prefix(id, Uniform(1, 3), Uniform(1, 3)) + RandomBytes(kChunkBytes);
      }
    }
  }

  Endpoint Sender() { return {0x7f000001, static_cast<std::uint16_t>(4000 + Uniform(0, 2))}; }

 private:
  std::size_t Uniform(std::size_t lo, std::size_t hi) {
    return std::uniform_int_distribution<std::size_t>(lo, hi)(rng_);
  }
  std::string RandomBytes(std::size_t n) {
    std::string s(n, '\0');
    for (auto& c : s) c = static_cast<char>(Uniform(0, 255));
    return s;
  }
  std::string RandomText(std::size_t n) {
    static constexpr char kAlphabet[] = "SNindextmsgda:[]{}-,\n \"'&*!|>#%@`0123456789.e";
    std::string s(n, ' ');
    for (auto& c : s) c = kAlphabet[Uniform(0, sizeof(kAlphabet) - 2)];
    return s;
  }
  std::string Genuine(std::uint32_t id) {
    std::string d = genuine_[Uniform(0, genuine_.size() - 1)];
    std::memcpy(d.data(), &id, 4);
    return d;
  }
  std::string WrongHeader() {
    static const char* kTypes[] = {"mat", "f64", "i32", "img", "u8", "[]", "~"};
    static const char* kNumbers[] = {"0",
                                     "1",
                                     "3",
                                     "-1",
                                     "400",
                                     "9600",
                                     "1e30",
                                     "x",
                                     "4294967296",
                                     "9223372036854775807",
                                     "-9223372036854775808"};
    std::string header = "SN: S\nindex: " + std::string(kNumbers[Uniform(0, 10)]) +
                         "\ntimestamp: " + kNumbers[Uniform(0, 10)] + "\ndata:\n";
    for (int k = Uniform(0, 3); k > 0; --k) {
      header += "  - {name: " + std::string(Uniform(0, 1) ? "3D_Positions" : "InitializeProgress") +
                ", type: " + kTypes[Uniform(0, 6)] + ", dtype: " + (Uniform(0, 3) ? "f64" : "f32") +
                ", width: " + kNumbers[Uniform(0, 10)] + ", height: " + kNumbers[Uniform(0, 10)] +
                ", offset: " + kNumbers[Uniform(0, 10)] + ", length: " + kNumbers[Uniform(0, 10)] +
                "}\n";
    }
    return header;
  }

  std::mt19937_64 rng_;
  std::vector<std::string> genuine_;
  std::string genuine_header_;
};

std::optional<ReceivedFrame> PushAll(FrameAssembler* assembler,
                                     const TactileFrame& frame,
                                     std::uint32_t id,
                                     double now_s) {
  EncodedFrame encoded;
  EncodeFrame(frame, id, cv::Mat(), ExtraItems(), &encoded);
  std::optional<ReceivedFrame> out;
  for (const auto& d : encoded.Datagrams()) {
    if (auto r = assembler->Push({0x7f000001, 4000}, Bytes(d), now_s)) out = std::move(r);
  }
  return out;
}

TEST(Fuzz, AssemblerSurvivesMalformedDatagramsAndStillDecodes) {
  DatagramFuzzer fuzzer;
  FrameAssembler assembler;
  double now_s = 0.0;
  for (int k = 0; k < 30000; ++k) {
    now_s += k % 2000 == 0 ? 2.0 : 1e-3;  // now and then a pause longer than the timeout
    const auto frame = assembler.Push(fuzzer.Sender(), Bytes(fuzzer.Next()), now_s);
    if (frame) {
      // Only a genuine frame's own bytes can decode (a flip that keeps YAML and shapes valid).
      EXPECT_EQ(frame->frame.Find(kFieldPositions)->matrix.rows(), 16);
    }
    ASSERT_LE(assembler.num_in_progress(), 30);
  }
  const DropCounts& drops = assembler.drops();
  std::cout << "fuzz drops: " << drops.ToString() << "\n";
  for (int r = 0; r < kNumDropReasons; ++r) {
    EXPECT_GT(drops.counts[r], 0) << "the fuzzer never produced "
                                  << DropReasonName(static_cast<DropReason>(r));
  }
  // A good frame with an id the fuzzer used still decodes exactly.
  const TactileFrame good = MakeSyntheticTactileFrame("AD2-0065L", 99);
  const auto out = PushAll(&assembler, good, 1000, now_s + 5.0);
  ASSERT_TRUE(out) << assembler.last_error();
  EXPECT_EQ(out->frame.Find(kFieldForces)->matrix(399, 0), good.forces_n[399].x());
}

TEST(Fuzz, ClientSocketSurvivesMalformedDatagramsAndStillReceives) {
  Client client({.bind_address = "127.0.0.1", .port = 0});
  UdpSender sender({.host = "127.0.0.1", .port = client.local_endpoint().port});
  internal::UdpSocket attacker(ResolveEndpoint("127.0.0.1", 0));
  DatagramFuzzer fuzzer;
  for (int k = 0; k < 3000; ++k) {
    const std::string d = fuzzer.Next();
    attacker.SendTo(client.local_endpoint(), {d});
    if (k % 50 == 49) {  // drain, so the kernel's buffer does not overflow
      while (client.Receive(0.0)) {
      }
    }
  }
  while (client.Receive(0.0)) {
  }
  EXPECT_GT(client.drops().total(), 0);
  const TactileFrame good = MakeSyntheticTactileFrame("AD2-0065L", 5);
  sender.Send(good);
  std::optional<ReceivedFrame> out;
  // Fragments of the fuzzer's genuine frame may still complete one: skip those.
  while ((out = client.Receive(5.0)) && out->frame.sn == "FUZZ") {
  }
  ASSERT_TRUE(out) << client.drops().ToString();
  EXPECT_EQ(out->frame.sn, "AD2-0065L");
  EXPECT_EQ(out->frame.Find(kFieldPositions)->matrix(7, 1), good.positions_mm[7].y());
}

TEST(Fuzz, SenderCommandSocketIgnoresGarbageAndStillTakesCommands) {
  Client client({.bind_address = "127.0.0.1", .port = 0});
  UdpSender sender({.host = "127.0.0.1", .port = client.local_endpoint().port});
  internal::UdpSocket attacker(ResolveEndpoint("127.0.0.1", 0));
  std::mt19937_64 rng(testing::kRandomSeed);
  static const std::string kNearMisses[] = {"$", "$c", "$q", "C$", "$C\n", "$Q\0", "$CQ", ""};
  int sent = 0;
  for (int k = 0; k < 2000; ++k) {
    std::string d = kNearMisses[rng() % 8];
    if (rng() % 2) {
      d.resize(rng() % 100);
      for (auto& c : d) c = static_cast<char>(rng() % 4 == 0 ? '$' : rng() % 256);
    }
    if (d == "$C" || d == "$Q") continue;
    attacker.SendTo(sender.local_endpoint(), {d});
    ++sent;
    if (k % 50 == 49) {
      EXPECT_EQ(sender.PollCommand(), std::nullopt);
    }
  }
  EXPECT_EQ(sender.PollCommand(), std::nullopt);
  EXPECT_EQ(sender.ignored_datagrams(), sent);
  client.SendCommand(sender.local_endpoint(), SensorCommand::kStop);
  std::optional<SensorCommand> command;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!command && std::chrono::steady_clock::now() < end) {
    command = sender.PollCommand();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(command, SensorCommand::kStop);
}

}  // namespace
}  // namespace tac3d
