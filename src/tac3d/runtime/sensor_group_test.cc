// Several sensors in one `tac3d run`: three twin datasets streamed at 30 fps on
// their own threads, every frame of each counted on UDP by SN, each on its own pace on one
// clock; a sensor whose dataset disappears mid-run, or that cannot start, is reported and the
// others go on. And the run file's validation. The compliance is the synthetic stand-in (the
// FEM model takes a minute to build); all else is what `tac3d run --run-file` runs.
// The tests wait on events (frames given, frames received), never on a sleep: a loaded 2-core
// machine may hold any thread back for a second.
#include "tac3d/runtime/sensor_group.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "tac3d/runtime/run_file.h"
#include "tac3d/dataset/twin_dataset.h"
#include "tac3d/force/test_compliance.h"
#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/protocol/client.h"
#include "tac3d/record/recording.h"
#include "tac3d/sensor/default_sensor.h"
#include "tac3d/sensor/test_sensor.h"
#include "tac3d/testing/testing.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/util/error.h"

namespace tac3d::runtime {
namespace {

using testing::DefaultSensor;

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr int kSteps = 30;
constexpr double kFps = 30.0;

// A twin dataset of undeformed frames at `times_s` (three rendered noise seeds, reused).
std::string MakeDataset(const std::string& dir, const std::vector<double>& times_s) {
  static const std::vector<cv::Mat> images = [] {
    MarkerImageRenderer renderer(DefaultSensor());
    std::vector<cv::Mat> out;
    for (int k = 0; k < 3; ++k) {
      out.push_back(renderer.Render(DefaultSensor().MarkerPositions(), k));
    }
    return out;
  }();
  TwinDatasetWriter writer(dir, {{"name", "sensor_group_test"}});
  for (int k = 0; k < static_cast<int>(times_s.size()); ++k) {
    TwinStep step;
    step.index = k;
    step.t_s = times_s[k];
    step.image = images[k % images.size()];
    writer.Write(step);
  }
  return dir;
}

// kSteps frames at kFps, made once; the sensors read it each on its own (a copy where the test
// deletes it).
const std::string& Dataset() {
  static const std::string dir = [] {
    std::vector<double> times_s;
    for (int k = 0; k < kSteps; ++k) times_s.push_back(k / kFps);
    return MakeDataset(testing::MakeTempDir("dataset") + "/ds", times_s);
  }();
  return dir;
}

ModelLoader SyntheticModel() {
  return [](const SensorConfig& config) {
    auto model = std::make_shared<fem::ComplianceModel>();
    model->h = testing::DefaultSyntheticCompliance();
    model->marker_positions = config.MarkerPositions();
    return std::shared_ptr<const fem::ComplianceModel>(model);
  };
}

SensorRunSpec TwinSensor(const std::string& sn, const std::string& dataset, std::uint16_t udp_port) {
  SensorRunSpec spec;
  spec.sn = sn;
  spec.source = "dataset:" + dataset;
  spec.speed = 1.0;
  spec.reference_frames = 5;
  spec.outputs.udp = fmt::format("127.0.0.1:{}", udp_port);
  spec.outputs.udp_progress = true;  // every frame is counted, the initialising ones too
  return spec;
}

// Only a frame lost or a sensor held up by another waits this long; no scheduling does.
constexpr std::chrono::seconds kHungAfter{60};

// Every frame a Tac3D client receives, by SN: index -> the sender's timestamp.
class Receiver {
 public:
  // An incomplete frame is kept until kHungAfter: a sender descheduled between two datagrams
  // of a frame (a loaded machine) must not lose it.
  Receiver()
      : client_({.bind_address = "127.0.0.1",
                 .port = 0,
                 .assembler = {.timeout_s = std::chrono::duration<double>(kHungAfter).count()}}) {
    thread_ = std::thread([this] {
      while (!done_) {
        if (std::optional<ReceivedFrame> r = client_.Receive(0.02)) {
          std::lock_guard lock(mutex_);
          frames_[r->frame.sn][r->frame.index] = r->frame.timestamp_s;
          arrived_.notify_all();
        }
      }
    });
  }
  ~Receiver() { Stop(); }
  std::uint16_t port() const { return client_.local_endpoint().port; }
  // Waits until `count` frames of `sn` have arrived (a sender's datagrams may still be on their
  // way through the kernel when it returns); false if they did not within kHungAfter.
  bool WaitForFrames(const std::string& sn, long count) {
    std::unique_lock lock(mutex_);
    return arrived_.wait_for(lock, kHungAfter, [&] { return static_cast<long>(frames_[sn].size()) >= count; });
  }
  void Stop() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::map<std::int64_t, double> Frames(const std::string& sn) {
    std::lock_guard lock(mutex_);
    return frames_[sn];
  }

 private:
  Client client_;
  std::atomic<bool> done_{false};
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::map<std::string, std::map<std::int64_t, double>> frames_;
  std::thread thread_;
};

// How late frame k arrived behind its due time k / fps on the common clock: the largest and
// the smallest (negative: early) over the frames.
std::pair<double, double> Lateness(const std::map<std::int64_t, double>& frames) {
  double latest = -1e9, earliest = 1e9;
  for (const auto& [index, t] : frames) {
    latest = std::max(latest, t - index / kFps);
    earliest = std::min(earliest, t - index / kFps);
  }
  return {latest, earliest};
}

TEST(SensorGroup, ThreeTwinSensorsDeliverEveryFrameOnOneClock) {
  Receiver receiver;
  std::vector<SensorRunSpec> sensors;
  for (const char* sn : {"HAND-A", "HAND-B", "HAND-C"}) sensors.push_back(TwinSensor(sn, Dataset(), receiver.port()));
  const std::atomic<bool> stop{false};
  const std::vector<SensorReport> reports = RunSensorGroup(sensors, SyntheticModel(), {}, nullptr, stop);
  for (const SensorReport& r : reports) EXPECT_TRUE(receiver.WaitForFrames(r.sn, r.frames)) << r.BriefReport();
  receiver.Stop();

  ASSERT_EQ(reports.size(), 3u);
  for (const SensorReport& r : reports) {
    SCOPED_TRACE(r.BriefReport());
    EXPECT_EQ(r.frames, kSteps);
    EXPECT_EQ(r.skipped, 0);
    EXPECT_EQ(r.failure, "");
    const std::map<std::int64_t, double> frames = receiver.Frames(r.sn);
    EXPECT_EQ(frames.size(), static_cast<size_t>(kSteps)) << "frames received over UDP";
    const auto [latest, earliest] = Lateness(frames);
    // Paced from the common epoch: never early (1 ms for the clock's rounding). How late is the
    // machine's scheduling (seconds at load 20 on 2 cores): printed, not asserted.
    EXPECT_GE(earliest, -1e-3);
    std::printf("%s; over UDP: %zu frames, lateness behind k/30 s on the common clock %.1f-%.1f ms\n",
                r.BriefReport().c_str(), frames.size(), 1e3 * earliest, 1e3 * latest);
  }
}

// HAND-C's dataset disappears after its 10th frame, HAND-D's does not exist, HAND-E is held in its
// first frame (a source that waits: a stalled camera, a slow dataset) until HAND-A and HAND-B
// have given every frame, and they give their last only once HAND-E is held. Threads get there
// whatever the scheduling; a runner serving the sensors one after the other, or frame by frame
// in turn, never does (the waits give up after kHungAfter and the test fails).
TEST(SensorGroup, ASensorThatFailsOrWaitsHoldsUpNoOther) {
  constexpr int kRemovedAfter = 10;
  const std::string dir = testing::MakeTempDir("failing");
  fs::copy(Dataset(), dir + "/HAND-C", fs::copy_options::recursive);
  Receiver receiver;
  std::vector<SensorRunSpec> sensors;
  for (const char* sn : {"HAND-A", "HAND-B"}) sensors.push_back(TwinSensor(sn, Dataset(), receiver.port()));
  sensors.push_back(TwinSensor("HAND-C", dir + "/HAND-C", receiver.port()));
  sensors.push_back(TwinSensor("HAND-D", dir + "/missing", receiver.port()));
  sensors.push_back(TwinSensor("HAND-E", Dataset(), receiver.port()));

  // The events, on the sensors' threads: on_frame is called with each frame before its outputs.
  std::mutex mutex;
  std::condition_variable given;
  std::map<std::string, int> frames_given;
  bool held = false, others_ran_while_held = false, a_and_b_saw_the_hold = true;
  SensorGroupOptions options;
  options.on_frame = [&](const TactileFrame& frame) {
    std::unique_lock lock(mutex);
    const int n = ++frames_given[frame.sn];
    given.notify_all();
    if (frame.sn == "HAND-C" && n == kRemovedAfter) fs::remove_all(dir + "/HAND-C");
    if ((frame.sn == "HAND-A" || frame.sn == "HAND-B") && n == kSteps) {
      a_and_b_saw_the_hold &= given.wait_for(lock, kHungAfter, [&] { return held; });
    }
    if (frame.sn == "HAND-E" && n == 1) {
      held = true;
      given.notify_all();
      others_ran_while_held = given.wait_for(lock, kHungAfter, [&] {
        return frames_given["HAND-A"] == kSteps && frames_given["HAND-B"] == kSteps;
      });
    }
  };
  const std::atomic<bool> stop{false};
  const std::vector<SensorReport> reports = RunSensorGroup(sensors, SyntheticModel(), options, nullptr, stop);
  for (const SensorReport& r : reports) EXPECT_TRUE(receiver.WaitForFrames(r.sn, r.frames)) << r.BriefReport();
  receiver.Stop();

  ASSERT_EQ(reports.size(), 5u);
  EXPECT_TRUE(a_and_b_saw_the_hold) << "HAND-E was not held before HAND-A and HAND-B gave their last frame";
  EXPECT_TRUE(others_ran_while_held) << "HAND-A and HAND-B did not finish while HAND-E was held";
  // HAND-E's second frame was stamped after the hold, every frame of A and B before it ended.
  const std::map<std::int64_t, double> held_frames = receiver.Frames("HAND-E");
  ASSERT_TRUE(held_frames.contains(1));
  const double released_s = held_frames.at(1);
  for (int i : {0, 1}) {
    SCOPED_TRACE(reports[i].BriefReport());
    EXPECT_EQ(reports[i].frames, kSteps);
    EXPECT_EQ(reports[i].failure, "");
    const std::map<std::int64_t, double> frames = receiver.Frames(reports[i].sn);
    EXPECT_EQ(frames.size(), static_cast<size_t>(kSteps));
    EXPECT_GE(Lateness(frames).second, -1e-3) << "a frame sent before its time";
    const long before_release = std::count_if(frames.begin(), frames.end(), [&](const auto& f) {
      return f.second < released_s;
    });
    EXPECT_EQ(before_release, kSteps) << "frames sent before HAND-E was released";
    std::printf("%s; %ld frames sent before HAND-E was released at %.2f s\n", reports[i].BriefReport().c_str(),
                before_release, released_s);
  }
  const SensorReport& killed = reports[2];
  std::printf("%s\n", killed.BriefReport().c_str());
  EXPECT_EQ(killed.frames, kRemovedAfter);
  EXPECT_EQ(killed.skipped, kSteps - kRemovedAfter);
  EXPECT_EQ(killed.failure, "");
  EXPECT_THAT(killed.BriefReport(), HasSubstr("HAND-C"));
  EXPECT_THAT(killed.last_skip, HasSubstr(dir + "/HAND-C"));
  const SensorReport& missing = reports[3];
  std::printf("%s\n", missing.BriefReport().c_str());
  EXPECT_EQ(missing.frames, 0);
  EXPECT_THAT(missing.failure, HasSubstr("could not start"));
  EXPECT_THAT(missing.failure, HasSubstr(dir + "/missing"));
  const SensorReport& waiting = reports[4];
  std::printf("%s\n", waiting.BriefReport().c_str());
  EXPECT_EQ(waiting.frames, kSteps);
  EXPECT_EQ(waiting.failure, "");
}

// A recording of `frames` synthetic frames, 1 ms apart, in `dir`.
std::string MakeRecording(const std::string& dir, int frames) {
  const std::string path = dir + "/r.tac3drec";
  RecordingWriter writer(path);
  for (int i = 0; i < frames; ++i) {
    TactileFrame frame = MakeSyntheticTactileFrame("REC", i);
    frame.timestamp_s = 1e-3 * i;
    writer.Write(frame, cv::Mat());
  }
  return path;
}

SensorRunSpec ReplaySensor(const std::string& sn, const std::string& recording) {
  SensorRunSpec spec;
  spec.sn = sn;
  spec.source = "recording:" + recording;
  spec.speed = 0.0;
  return spec;
}

// While it lives, every new thread asks for a stack larger than any address space, so
// pthread_create fails (EAGAIN) as it does when a run of many sensors has used up its address
// space (`prlimit --as=4000000000`).
class ThreadsCannotStart {
 public:
  ThreadsCannotStart() {
    pthread_getattr_default_np(&saved_);
    pthread_attr_t huge;
    pthread_attr_init(&huge);
    pthread_attr_setstacksize(&huge, std::size_t{1} << 47);
    pthread_setattr_default_np(&huge);
    pthread_attr_destroy(&huge);
  }
  ~ThreadsCannotStart() {
    pthread_setattr_default_np(&saved_);
    pthread_attr_destroy(&saved_);
  }

 private:
  pthread_attr_t saved_;
};

// Once a std::thread that could not start left the others joinable when their
// vector was destroyed: std::terminate ("terminate called without an active exception").
// A paced dataset whose next frame is due in 11 days: a stop request (Ctrl-C, a client's $Q)
// ends the wait at once, not when the frame is due.
TEST(SensorStream, AStopEndsAPacedDatasetsLongGap) {
  SensorRunSpec spec;
  spec.source = "dataset:" + MakeDataset(testing::MakeTempDir("gap") + "/ds", {0.0, 0.001, 1e6});
  spec.speed = 1.0;
  spec.reference_frames = 2;
  const std::unique_ptr<SensorStream> stream = OpenSensorStream(spec, SyntheticModel());
  stream->Start({.epoch = std::chrono::steady_clock::now()});
  std::atomic<bool> stop{false};
  ProducedFrame out;
  for (int reference = 0; reference < 2; ++reference) EXPECT_EQ(stream->Next(stop, out), Produced::kFrame);
  stop = true;
  EXPECT_EQ(stream->Next(stop, out), Produced::kEnd);
}

TEST(SensorGroup, AThreadThatCannotStartFailsItsSensorNotTheRun) {
  const std::string recording = MakeRecording(testing::MakeTempDir("threads"), 5);
  const std::vector<SensorRunSpec> sensors = {ReplaySensor("A", recording), ReplaySensor("B", recording)};
  const std::atomic<bool> stop{false};
  std::vector<SensorReport> reports;
  {
    ThreadsCannotStart no_threads;
    reports = RunSensorGroup(sensors, SyntheticModel(), {}, nullptr, stop);
  }
  ASSERT_EQ(reports.size(), 2u);
  for (const SensorReport& r : reports) {
    EXPECT_EQ(r.frames, 0);
    EXPECT_THAT(r.failure, HasSubstr("could not start its thread"));
  }
  // And with threads to be had, the same sensors run.
  reports = RunSensorGroup(sensors, SyntheticModel(), {}, nullptr, stop);
  EXPECT_EQ(reports[0].frames, 5);
  EXPECT_EQ(reports[1].failure, "");
}

// An exception that is not a tac3d::Error (std::bad_alloc, say) on a sensor's thread fails that
// sensor; once it escaped the thread: std::terminate.
TEST(SensorGroup, AnyExceptionOnASensorsThreadFailsOnlyThatSensor) {
  const std::string recording = MakeRecording(testing::MakeTempDir("throws"), 5);
  const std::vector<SensorRunSpec> sensors = {ReplaySensor("A", recording), ReplaySensor("B", recording)};
  SensorGroupOptions options;
  options.on_frame = [](const TactileFrame& frame) {
    if (frame.sn == "A" && frame.index == 2) throw std::bad_alloc();
  };
  const std::atomic<bool> stop{false};
  const std::vector<SensorReport> reports = RunSensorGroup(sensors, SyntheticModel(), options, nullptr, stop);
  EXPECT_EQ(reports[0].frames, 2);
  EXPECT_THAT(reports[0].failure, HasSubstr("out of memory"));
  EXPECT_EQ(reports[1].frames, 5);
  EXPECT_EQ(reports[1].failure, "");
}

// Many sensors: the limit is refused before any work, and the most a run holds all run.
TEST(SensorGroup, RunsUpToTheLimitOfSensorsAndRefusesMore) {
  const std::string recording = MakeRecording(testing::MakeTempDir("many"), 3);
  std::vector<SensorRunSpec> sensors;
  for (int i = 0; i < kMaxSensors; ++i) sensors.push_back(ReplaySensor(fmt::format("S{}", i), recording));
  const std::atomic<bool> stop{false};
  const std::vector<SensorReport> reports = RunSensorGroup(sensors, SyntheticModel(), {}, nullptr, stop);
  ASSERT_EQ(reports.size(), static_cast<size_t>(kMaxSensors));
  for (const SensorReport& r : reports) EXPECT_EQ(r.frames, 3) << r.BriefReport();
  sensors.push_back(ReplaySensor("ONE-TOO-MANY", recording));
  EXPECT_THAT([&] { RunSensorGroup(sensors, SyntheticModel(), {}, nullptr, stop); },
              ThrowsMessage<Error>(HasSubstr(fmt::format("{} sensors: a run holds at most {}", kMaxSensors + 1,
                                                         kMaxSensors))));
}

// A sensor's record file is checked against what the sensor reads: never its recording, nor a
// file inside its dataset folder.
TEST(SensorRunSpec, RefusesARecordFileThatIsWhatTheSensorReads) {
  const std::string dir = testing::MakeTempDir("record_input");
  const std::string recording = dir + "/in.rec";
  std::FILE* file = std::fopen(recording.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  std::fclose(file);
  SensorRunSpec spec;
  spec.sn = "A";
  spec.source = "recording:" + recording;
  spec.outputs.record = recording;
  EXPECT_THAT([&] { spec.Validate(); },
              ThrowsMessage<Error>(HasSubstr(fmt::format("sensor A: --record '{0}' is the input '{0}'", recording))));
  spec.source = "dataset:" + dir;
  EXPECT_THAT([&] { spec.Validate(); },
              ThrowsMessage<Error>(HasSubstr(fmt::format("would replace a file inside the input folder '{}'", dir))));
  spec.outputs.record = testing::MakeTempDir("record_output") + "/out.rec";
  EXPECT_NO_THROW(spec.Validate());
}

// Parses `text` as a run file in /tmp and returns the error, or "" if it was accepted.
std::string RunFileError(const std::string& text) {
  try {
    ParseRunFile(text, "hand.yaml", "/tmp");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(RunFile, ReadsEachSensorWithPathsFromItsFolder) {
  const std::vector<SensorRunSpec> sensors = ParseRunFile(
      "sensors:\n"
      "  - sn: THUMB\n"
      "    source: dataset:twin/thumb\n"
      "    config: thumb.yaml\n"
      "    gains: [1.1, 1.2, 0.9]\n"
      "    speed: 1\n"
      "    udp: 127.0.0.1:9988\n"
      "    udp_items: 3D_Normals,SlipState\n"
      "    udp_progress: true\n"
      "    allow_zero_under_load: true\n"
      "    record: thumb.rec\n"
      "    record_images: true\n"
      "    overwrite: true\n"
      "  - sn: INDEX\n"
      "    source: camera:2\n"
      "    weight: 0.1\n"
      "    reference_frames: 10\n"
      "    drift: rezero\n"
      "    drift_time_constant_s: 5\n",
      "hand.yaml", "/tmp");
  ASSERT_EQ(sensors.size(), 2u);
  EXPECT_EQ(sensors[0].sn, "THUMB");
  EXPECT_EQ(sensors[0].source, "dataset:/tmp/twin/thumb");
  EXPECT_EQ(sensors[0].config, "/tmp/thumb.yaml");
  EXPECT_THAT(sensors[0].gains, EigenNear(Eigen::Vector3d(1.1, 1.2, 0.9), 0.0));
  EXPECT_EQ(sensors[0].speed, 1.0);
  EXPECT_EQ(sensors[0].outputs.udp, "127.0.0.1:9988");
  EXPECT_EQ(sensors[0].outputs.udp_items, "3D_Normals,SlipState");
  EXPECT_TRUE(sensors[0].outputs.udp_progress);
  EXPECT_EQ(sensors[1].outputs.udp_items, "");
  EXPECT_FALSE(sensors[1].outputs.udp_progress);
  EXPECT_TRUE(sensors[0].outputs.allow_zero_under_load);
  EXPECT_FALSE(sensors[1].outputs.allow_zero_under_load);
  EXPECT_EQ(sensors[0].outputs.record, "/tmp/thumb.rec");
  EXPECT_TRUE(sensors[0].outputs.record_images);
  EXPECT_TRUE(sensors[0].outputs.overwrite);
  EXPECT_FALSE(sensors[1].outputs.overwrite);
  EXPECT_EQ(sensors[0].outputs.sn, "THUMB");
  EXPECT_EQ(sensors[1].source, "camera:2");
  EXPECT_EQ(sensors[0].drift.mode, DriftMode::kFlag);
  EXPECT_EQ(sensors[1].drift.mode, DriftMode::kRezero);
  EXPECT_EQ(sensors[1].drift.time_constant_s, 5.0);
  EXPECT_EQ(sensors[1].config, "");
  EXPECT_EQ(sensors[1].weight, 0.1);
  EXPECT_EQ(sensors[1].reference_frames, 10);
  EXPECT_FALSE(sensors[1].speed.has_value());
  EXPECT_EQ(sensors[1].outputs.record, "");
}

TEST(RunFile, RefusesMistakesNamingTheLine) {
  const std::string a = "sensors:\n  - sn: A\n    source: camera:0\n";
  EXPECT_EQ(RunFileError(a), "");
  EXPECT_THAT(RunFileError(a + "    sn: B\n"), HasSubstr("hand.yaml: line 4: duplicated key 'sn' (first at line 2)"));
  EXPECT_THAT(RunFileError(a + "    colour: red\n"), HasSubstr("hand.yaml: line 4: sensors[0].colour: unknown key"));
  EXPECT_THAT(RunFileError(a + "  - sn: B\n"), HasSubstr("hand.yaml: line 4: sensors[1].source: missing"));
  EXPECT_THAT(RunFileError(a + "  - sn: A\n    source: camera:1\n"),
              HasSubstr("hand.yaml: line 4: sensors[1]: sn 'A' is used twice (first at line 2)"));
  EXPECT_THAT(RunFileError(a + "    speed: 2\n"),
              HasSubstr("hand.yaml: line 4: sensors[0].speed: applies to recording:FILE, vendor:DIR or dataset:DIR only"));
  EXPECT_THAT(RunFileError(a + "    gains: [1, 2]\n"), HasSubstr("line 4: sensors[0].gains: must be a list of 3"));
  EXPECT_THAT(RunFileError(a + "    record_images: maybe\n"), HasSubstr("line 4: sensors[0].record_images: must be true or false"));
  EXPECT_THAT(RunFileError(a + "    drift: sometimes\n"),
              HasSubstr("line 4: sensors[0].drift: must be off, flag or rezero"));
  EXPECT_THAT(RunFileError(a + "    drift_time_constant_s: 0\n"),
              HasSubstr("line 4: sensors[0].drift_time_constant_s: must be > 0"));
  EXPECT_THAT(RunFileError(a + "    udp: nowhere\n"),
              HasSubstr("hand.yaml: line 4: sensors[0].udp: --udp 'nowhere': expected HOST:PORT"));
  const std::string udp = a + "    udp: 127.0.0.1:9988\n";
  EXPECT_THAT(RunFileError(udp + "    udp_items: all,Slip\n"),
              HasSubstr("hand.yaml: line 5: sensors[0].udp_items: --udp-items 'all,Slip': unknown item "
                        "'Slip'; the items to add to the vendor's six are 3D_Normals, SlipState, "
                        "SlipFraction, Friction, FrictionSigma, SlipMargin (or all)"));
  EXPECT_THAT(RunFileError(a + "    udp_items: all\n"),
              HasSubstr("hand.yaml: line 4: sensors[0].udp_items: --udp-items needs --udp HOST:PORT"));
  EXPECT_THAT(RunFileError(a + "    udp_progress: true\n"),
              HasSubstr("hand.yaml: line 4: sensors[0].udp_progress: --udp-progress needs --udp HOST:PORT"));
  EXPECT_THAT(RunFileError(udp + "    udp_progress: 1.5\n"),
              HasSubstr("line 5: sensors[0].udp_progress: must be true or false"));
  EXPECT_THAT(RunFileError(a + "    record: missing/r.rec\n"),
              HasSubstr("hand.yaml: line 4: sensors[0].record: "));
  EXPECT_THAT(RunFileError("sensors: []\n"), HasSubstr("hand.yaml: line 1: sensors: lists no sensor"));
  std::string many = "sensors:\n";
  for (int i = 0; i < 2000; ++i) many += fmt::format("  - {{sn: S{}, source: imgs}}\n", i);
  EXPECT_THAT(RunFileError(many), HasSubstr(fmt::format("hand.yaml: line {}: sensors[{}]: a run holds at most {} sensors",
                                                        kMaxSensors + 2, kMaxSensors, kMaxSensors)));
  EXPECT_THAT(RunFileError("sensor:\n  - sn: A\n"), HasSubstr("hand.yaml: line 1: sensors: missing"));
  EXPECT_THAT(RunFileError(a + "  - sn: B\n    source: x.avi\n    record: r.rec\n  - sn: C\n    source: y.avi\n"
                               "    record: ./r.rec\n"),
              HasSubstr("line 7: sensors[2]: record file '/tmp/r.rec' is used twice (first at line 4)"));
}

}  // namespace
}  // namespace tac3d::runtime
