#include "tac3d/ros2/ros2_publisher.h"

#include <dds/dds.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "std_msgs_empty.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"

namespace tac3d {
namespace {

TEST(Ros2Namespace, FullFormAndRefusals) {
  EXPECT_EQ(Ros2Namespace("tac3d/left"), "/tac3d/left");
  EXPECT_EQ(Ros2Namespace("/hand_1/index"), "/hand_1/index");
  for (const char* bad : {"", "/", "tac3d/", "a//b", "1st", "a/2b", "a-b", "a b", "~/x", "{ns}"}) {
    EXPECT_THROW(Ros2Namespace(bad), Error) << bad;
  }
  EXPECT_THROW(Ros2Namespace(std::string(kMaxRos2NamespaceLength + 1, 'a')), Error);
}

TEST(Ros2PublisherOptions, Validate) {
  Ros2PublisherOptions options{.ns = "tac3d", .frame_id = "finger_tip"};
  EXPECT_NO_THROW(options.Validate());
  options.frame_id = "/finger_tip";
  EXPECT_THROW(options.Validate(), Error);
  options.frame_id = "tip.1";
  EXPECT_THROW(options.Validate(), Error);
  options.frame_id = "";
  options.status_period_s = -1;
  EXPECT_THROW(options.Validate(), Error);
}

// Environment variables set for one test, restored after it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_, old_->c_str(), 1);
    else ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// Loopback only, so the test neither needs nor disturbs a network.
std::string LoopbackConfig() {
  const std::string path = testing::MakeTempDir("ros2_publisher") + "/cyclonedds.xml";
  std::ofstream(path) << R"(<CycloneDDS><Domain id="any"><General>
  <Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><Peers><Peer address="127.0.0.1"/></Peers><ParticipantIndex>auto</ParticipantIndex></Discovery>
</Domain></CycloneDDS>)";
  return "file://" + path;
}

TEST(Ros2Publisher, RefusesABadConfigOrDomainWithAnError) {
  {
    const ScopedEnv uri("CYCLONEDDS_URI", "<CycloneDDS><Domain><General><NoSuchElement/></General></Domain></CycloneDDS>");
    EXPECT_THROW(Ros2Publisher({.ns = "bad_config"}), Error);
  }
  {
    const ScopedEnv uri("CYCLONEDDS_URI", LoopbackConfig());
    const ScopedEnv domain("ROS_DOMAIN_ID", "300");
    EXPECT_THROW(Ros2Publisher({.ns = "bad_domain"}), Error);
  }
}

// A std_msgs/Empty on NAMESPACE/zero, from another participant of the domain, is a zero request.
TEST(Ros2Publisher, ZeroRequestFromTheZeroTopic) {
  const ScopedEnv uri("CYCLONEDDS_URI", LoopbackConfig());
  const ScopedEnv domain("ROS_DOMAIN_ID", "211");
  Ros2Publisher publisher({.ns = "tac3d/zero_test"});
  EXPECT_EQ(publisher.topic_namespace(), "/tac3d/zero_test");
  EXPECT_FALSE(publisher.TakeZeroRequest());

  const dds_entity_t participant = dds_create_participant(211, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  const dds_entity_t topic =
      dds_create_topic(participant, &std_msgs_msg_dds__Empty__desc, "rt/tac3d/zero_test/zero", nullptr, nullptr);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  ASSERT_GT(writer, 0);
  const std_msgs_msg_dds__Empty_ empty{};
  ASSERT_EQ(dds_write(writer, &empty), DDS_RETCODE_OK);
  bool requested = false;
  for (int i = 0; i < 500 && !requested; ++i) {
    requested = publisher.TakeZeroRequest();
    if (!requested) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(requested);
  EXPECT_EQ(publisher.stats().zero_requests, 1);
  EXPECT_FALSE(publisher.TakeZeroRequest());  // taken once
  dds_delete(participant);
}

}  // namespace
}  // namespace tac3d
