// Loopback tests of UdpSender and Client: real sockets on 127.0.0.1, ephemeral ports.
#include <gtest/gtest.h>

#include <map>
#include <thread>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/protocol/client.h"
#include "tac3d/protocol/udp_sender.h"
#include "tac3d/protocol/udp_socket.h"
#include "tac3d/testing/testing.h"

namespace tac3d {
namespace {

using ::testing::HasSubstr;

// Generous waits: they bound a hang, they are not timing assertions.
constexpr double kWaitS = 5.0;

ClientOptions LoopbackClient() { return {.bind_address = "127.0.0.1", .port = 0}; }

UdpSender SenderTo(const Client& client) {
  return UdpSender({.host = "127.0.0.1", .port = client.local_endpoint().port});
}

// Polls until a command arrives or kWaitS passes.
std::optional<SensorCommand> WaitForCommand(UdpSender* sender) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(kWaitS);
  while (std::chrono::steady_clock::now() < end) {
    if (auto command = sender->PollCommand()) return command;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return std::nullopt;
}

TEST(Udp, FrameReachesTheClientAndCommandsReachTheSender) {
  Client client(LoopbackClient());
  UdpSender sender = SenderTo(client);
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 3);
  cv::Mat image(120, 160, CV_8UC1);
  cv::randu(image, 0, 256);
  sender.Send(frame, image);
  const auto received = client.Receive(kWaitS);
  ASSERT_TRUE(received) << client.drops().ToString() << " " << client.last_error();
  EXPECT_EQ(received->sender.port, sender.local_endpoint().port);
  EXPECT_EQ(received->frame.sn, "AD2-0065L");
  EXPECT_EQ(received->frame.index, 3);
  EXPECT_EQ(received->frame.Find(kFieldPositions)->matrix(399, 2), frame.positions_mm[399].z());
  EXPECT_EQ(received->frame.Find(kFieldNormals), nullptr);  // an extra item, not asked for
  EXPECT_EQ(cv::norm(received->frame.Find(kFieldImage)->image, image, cv::NORM_INF), 0.0);

  EXPECT_EQ(sender.PollCommand(), std::nullopt);
  client.SendCommand(received->sender, SensorCommand::kZero);
  client.SendCommand(received->sender, SensorCommand::kStop);
  EXPECT_EQ(WaitForCommand(&sender), SensorCommand::kZero);
  EXPECT_EQ(WaitForCommand(&sender), SensorCommand::kStop);
  EXPECT_EQ(sender.ignored_datagrams(), 0);
  EXPECT_EQ(client.drops().total(), 0);
}

TEST(Udp, SeveralSendersWithTheirOwnSnShareOneClient) {
  Client client(LoopbackClient());
  const std::vector<std::string> sns = {"AD2-0001L", "AD2-0001R", "AD2-0002L"};
  std::vector<UdpSender> senders;
  for (std::size_t s = 0; s < sns.size(); ++s) senders.push_back(SenderTo(client));
  std::map<std::string, std::vector<std::int64_t>> indices;
  std::map<std::string, Endpoint> from;
  for (int index = 0; index < 5; ++index) {
    // One frame from each, then read them: the kernel's receive buffer never overflows.
    for (std::size_t s = 0; s < sns.size(); ++s) {
      senders[s].Send(MakeSyntheticTactileFrame(sns[s], index));
    }
    for (std::size_t s = 0; s < sns.size(); ++s) {
      const auto received = client.Receive(kWaitS);
      ASSERT_TRUE(received) << client.drops().ToString();
      indices[received->frame.sn].push_back(received->frame.index);
      from[received->frame.sn] = received->sender;
    }
  }
  for (std::size_t s = 0; s < sns.size(); ++s) {
    EXPECT_EQ(indices[sns[s]], (std::vector<std::int64_t>{0, 1, 2, 3, 4})) << sns[s];
    EXPECT_EQ(from[sns[s]].port, senders[s].local_endpoint().port) << sns[s];
  }
  // A command goes to the one sensor it is addressed to.
  client.SendCommand(from["AD2-0001R"], SensorCommand::kZero);
  EXPECT_EQ(WaitForCommand(&senders[1]), SensorCommand::kZero);
  EXPECT_EQ(senders[0].PollCommand(), std::nullopt);
  EXPECT_EQ(senders[2].PollCommand(), std::nullopt);
}

// Frames with initialize_progress 20, 40, 100, 100 sent with `stream`, each read before the
// next is sent; the indices and InitializeProgress values the client receives.
std::vector<std::pair<std::int64_t, double>> SendInitialisation(const StreamOptions& stream) {
  Client client(LoopbackClient());
  UdpSender sender({.host = "127.0.0.1", .port = client.local_endpoint().port, .stream = stream});
  std::vector<std::pair<std::int64_t, double>> received;
  const int progress[] = {20, 40, 100, 100};
  for (int k = 0; k < 4; ++k) {
    TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", k);
    frame.initialize_progress = progress[k];
    const std::int64_t sent_before = sender.frames_sent();
    sender.Send(frame);
    if (sender.frames_sent() == sent_before) continue;
    const auto r = client.Receive(kWaitS);
    if (!r) break;
    const DecodedField* value = r->frame.Find(kFieldInitializeProgress);
    EXPECT_EQ(value->type, FieldType::kF64);
    received.emplace_back(r->frame.index, value->matrix(0, 0));
  }
  EXPECT_FALSE(client.Receive(0.05));
  EXPECT_EQ(sender.frames_sent() + sender.frames_withheld(), 4);
  return received;
}

TEST(Udp, InitialisingFramesAreWithheldUnlessAsked) {
  using Received = std::vector<std::pair<std::int64_t, double>>;
  EXPECT_EQ(SendInitialisation({}), (Received{{2, 100.0}, {3, 100.0}}));
  EXPECT_EQ(SendInitialisation({.send_initializing = true}),
            (Received{{0, 20.0}, {1, 40.0}, {2, 100.0}, {3, 100.0}}));
}

TEST(Udp, TheExtraItemsAskedForArrive) {
  Client client(LoopbackClient());
  UdpSender sender({.host = "127.0.0.1",
                    .port = client.local_endpoint().port,
                    .stream = {.items = "3D_Normals,Friction"}});
  const TactileFrame frame = MakeSyntheticTactileFrame("AD2-0065L", 104);  // gross slip
  sender.Send(frame);
  const auto received = client.Receive(kWaitS);
  ASSERT_TRUE(received) << client.drops().ToString() << " " << client.last_error();
  EXPECT_EQ(received->frame.Find(kFieldNormals)->matrix(399, 2), frame.normals[399].z());
  EXPECT_EQ(received->frame.slip.friction, frame.slip.friction);
  EXPECT_EQ(received->frame.Find(kFieldSlipState), nullptr);
  EXPECT_EQ(received->frame.slip.state, SlipState::kUnknown);  // not sent
}

TEST(Udp, SenderIgnoresMalformedCommandsAndStrangers) {
  Client client(LoopbackClient());
  UdpSender sender = SenderTo(client);
  const Endpoint to = sender.local_endpoint();
  internal::UdpSocket stranger(ResolveEndpoint("127.0.0.2", 0));
  stranger.SendTo(to, {"$C"});  // not from the destination address
  client.SendCommand(to, SensorCommand::kZero);
  internal::UdpSocket same_host(ResolveEndpoint("127.0.0.1", 0));
  same_host.SendTo(to, {"$CC"});
  same_host.SendTo(to, {"$Q"});
  EXPECT_EQ(WaitForCommand(&sender), SensorCommand::kZero);
  EXPECT_EQ(WaitForCommand(&sender), SensorCommand::kStop);
  EXPECT_EQ(sender.ignored_datagrams(), 2);
}

TEST(Udp, ReceiveReturnsNothingWhenNothingCame) {
  Client client(LoopbackClient());
  EXPECT_FALSE(client.Receive(0.01));
  EXPECT_FALSE(client.Receive(0.0));
}

TEST(Udp, SetupErrorsSayWhatFailed) {
  Client client(LoopbackClient());
  try {
    Client second({.bind_address = "127.0.0.1", .port = client.local_endpoint().port});
    ADD_FAILURE() << "bound a port in use";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot bind UDP 127.0.0.1:"));
  }
  EXPECT_THROW(ResolveEndpoint("no-such-host.invalid", 1), Error);
  EXPECT_THROW(UdpSender({.host = "", .port = 1}), Error);
  EXPECT_THROW(UdpSender({.host = "127.0.0.1", .port = 0}), Error);
  EXPECT_THAT([] { UdpSender({.host = "127.0.0.1", .port = 1, .stream = {.items = "Normals"}}); },
              ::testing::ThrowsMessage<Error>(
                  HasSubstr("StreamOptions.items 'Normals': unknown item 'Normals'")));
  EXPECT_THROW(Client({.receive_buffer_bytes = -1}), Error);
}

}  // namespace
}  // namespace tac3d
