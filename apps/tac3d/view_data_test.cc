// `tac3d view`'s endpoints (docs/viewer.md): a recording's frames by index for the time
// slider, their images, and a friction map's mesh coloured in the paper's bands.
#include "view_data.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "tac3d/frame/synthetic_frame.h"
#include "tac3d/friction/friction_output.h"
#include "tac3d/record/recording.h"
#include "tac3d/testing/image_message.h"
#include "tac3d/testing/testing.h"
#include "tac3d/tracking/marker_tracker.h"
#include "tac3d/util/error.h"

namespace tac3d::cli {
namespace {

using ::testing::HasSubstr;
using runtime::OpenRecordingStream;
using runtime::Produced;
using runtime::ProducedFrame;
using runtime::SensorRunSpec;
using runtime::SensorStream;
using runtime::StreamClock;
using runtime::StreamEnd;

constexpr int kFrames = 5;

// A recording of kFrames synthetic frames, 0.1 s apart; frames 0 and 2 with an image.
ViewData RecordedView() {
  const std::string path = testing::MakeTempDir("view") + "/r.rec";
  {
    RecordingWriter writer(path);
    for (int i = 0; i < kFrames; ++i) {
      TactileFrame frame = MakeSyntheticTactileFrame("VIEW-SN", i);
      frame.timestamp_s = 0.1 * i;
      writer.Write(frame, i % 2 == 0 && i < 3 ? cv::Mat(480, 640, CV_8UC1, cv::Scalar(40 * i)) : cv::Mat());
    }
  }
  SensorRunSpec spec;
  spec.speed = 0.0;
  const std::unique_ptr<SensorStream> stream = OpenRecordingStream(path, spec, /*replace_sn=*/false);
  ViewData view;
  view.LoadFrames(*stream, path);
  return view;
}

nlohmann::json Get(const ViewData& view, const std::string& target) {
  const std::optional<WebReply> reply = view.Handle(target);
  if (!reply) throw Error("404 for " + target);
  EXPECT_EQ(reply->content_type, "application/json");
  return nlohmann::json::parse(reply->body);
}

TEST(ViewData, ServesEachFrameByIndex) {
  const ViewData view = RecordedView();
  ASSERT_EQ(view.frames(), kFrames);
  const nlohmann::json all = Get(view, "/api/frames");
  EXPECT_EQ(all["count"], kFrames);
  EXPECT_EQ(all["sn"], "VIEW-SN");
  EXPECT_EQ(all["images"], 2);
  ASSERT_EQ(all["t"].size(), static_cast<size_t>(kFrames));
  EXPECT_NEAR(all["t"][3].get<double>(), 0.3, 1e-9);
  ASSERT_EQ(all["F"].size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    const nlohmann::json frame = Get(view, "/api/frame/" + std::to_string(i));
    EXPECT_EQ(frame["type"], "frame");
    EXPECT_EQ(frame["index"], i);
    EXPECT_NEAR(frame["t"].get<double>(), 0.1 * i, 1e-6);
    for (int k = 0; k < 3; ++k) {  // the frame message rounds to 4 decimals
      EXPECT_NEAR(frame["F"][k].get<double>(), all["F"][i][k].get<double>(), 1e-4);
    }
  }
  EXPECT_EQ(Get(view, "/api/frame/3?nocache=1")["index"], 3);
  EXPECT_FALSE(view.Handle("/api/frame/5"));
  EXPECT_FALSE(view.Handle("/api/friction-map"));  // none loaded
  EXPECT_FALSE(view.Handle("/api/other"));
  for (const char* bad : {"/api/frame/x", "/api/frame/-1", "/api/frame/", "/api/frame/2x"}) {
    EXPECT_THROW(view.Handle(bad), Error) << bad;
  }
}

TEST(ViewData, ServesTheImagesTheRecordingHas) {
  const ViewData view = RecordedView();
  const nlohmann::json image = Get(view, "/api/image/2");
  EXPECT_EQ(image["type"], "image");
  EXPECT_EQ(image["index"], 2);
  EXPECT_EQ(image["w"], 320);  // downscaled from 640
  EXPECT_FALSE(image["jpeg"].get<std::string>().empty());
  EXPECT_FALSE(view.Handle("/api/image/1"));
}

// A pipeline's stream as ViewData sees it: two frames with a grey image and the tracker's
// markers (a 1 x 2 grid a half: marker 0 tracked, marker 1 lost), without a pipeline.
class MarkedStream final : public SensorStream {
 public:
  MarkedStream() {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    observation_.rows = 1;
    observation_.cols = 2;
    for (int h = 0; h < 2; ++h) {
      HalfObservation& half = observation_.halves[h];
      half.uv = {At(2 * h), Eigen::Vector2d(nan, nan)};
      half.estimate_uv = {At(2 * h), At(2 * h + 1)};
      half.state = {MarkerState::kValid, MarkerState::kNotFound};
    }
  }
  // Marker k (left 0, left 1, right 0, right 1) in the full image, px.
  static Eigen::Vector2d At(int k) { return {100.0 + 300.0 * (k / 2) + 60.0 * (k % 2), 200.0 + 40.0 * (k % 2)}; }

  void Start(const StreamClock&) override {}
  Produced Next(const std::atomic<bool>&, ProducedFrame& out) override {
    if (next_ == 2) return Produced::kEnd;
    frame_ = MakeSyntheticTactileFrame("MARKED", next_++);
    out.frame = &frame_;
    out.image = &image_;
    out.markers = &observation_;
    return Produced::kFrame;
  }
  void Zero() override {}
  bool ZeroRetakesReference() const override { return true; }
  StreamEnd End(long) const override { return {}; }
  std::string Describe() const override { return "marked"; }

 private:
  int next_ = 0;
  TactileFrame frame_;
  cv::Mat image_ = cv::Mat(480, 640, CV_8UC1, cv::Scalar(128));
  MarkerObservation observation_;
};

// `tac3d view --dataset`: each frame's image with its markers drawn, tracked green, lost red;
// a recording's images (no marker pixels recorded) plain.
TEST(ViewData, DrawsTheMarkersOnADatasetsImagesNotOnARecordings) {
  MarkedStream stream;
  ViewData view;
  view.LoadFrames(stream, "marked");
  ASSERT_EQ(view.frames(), 2);
  for (int i = 0; i < 2; ++i) {
    const std::optional<WebReply> reply = view.Handle("/api/image/" + std::to_string(i));
    ASSERT_TRUE(reply);
    const cv::Mat image = testing::DecodeImageMessage(reply->body);
    ASSERT_EQ(image.size(), cv::Size(320, 240));
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d at = ((MarkedStream::At(k).array() + 0.5) * 0.5 - 0.5).matrix();
      const bool tracked = k % 2 == 0;
      EXPECT_GE(testing::CountPixelsNear(image, at, 4, tracked ? testing::IsMarkerGreen : testing::IsMarkerRed), 4)
          << "frame " << i << " marker " << k;
      EXPECT_EQ(testing::CountPixelsNear(image, at, 4, tracked ? testing::IsMarkerRed : testing::IsMarkerGreen), 0)
          << "frame " << i << " marker " << k;
    }
  }
  const ViewData recorded = RecordedView();
  const cv::Mat plain = testing::DecodeImageMessage(recorded.Handle("/api/image/2")->body);
  ASSERT_FALSE(plain.empty());
  EXPECT_EQ(testing::CountMarkerPixels(plain), 0);
}

TEST(ViewData, ColoursTheFrictionMapInThePapersBands) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  mesh.vertex_properties["mu"] = {0.3, 0.65, 0.95, std::numeric_limits<double>::quiet_NaN()};
  mesh.vertex_properties["confidence"] = {1.0, 2.0, 3.0, 0.0};
  const std::string dir = testing::MakeTempDir("map");
  WritePly(mesh, dir + "/map.ply");
  ViewData view;
  view.LoadFrictionMap(dir);  // the folder: its map.ply
  const nlohmann::json map = Get(view, "/api/friction-map");
  ASSERT_EQ(map["vertices"].size(), 12u);
  EXPECT_EQ(map["triangles"], nlohmann::json({0, 1, 2, 1, 3, 2}));
  EXPECT_TRUE(map["mu"][3].is_null());
  EXPECT_EQ(map["confidence"][2], 3.0);
  EXPECT_EQ(map["bands"], nlohmann::json({{"unknown", 1}, {"low", 1}, {"medium", 1}, {"high", 1}}));
  const friction::FrictionBand expected[] = {friction::FrictionBand::kLow, friction::FrictionBand::kMedium,
                                             friction::FrictionBand::kHigh, friction::FrictionBand::kUnknown};
  for (int v = 0; v < 4; ++v) {
    const std::array<std::uint8_t, 3> rgb = friction::BandColorRgb(expected[v]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(map["colors"][3 * v + k], rgb[k]) << "vertex " << v;
  }
  // A PLY without mu is refused, naming the file.
  mesh.vertex_properties.clear();
  WritePly(mesh, dir + "/plain.ply");
  try {
    view.LoadFrictionMap(dir + "/plain.ply");
    FAIL() << "accepted a PLY without mu";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(dir + "/plain.ply: no per-vertex 'mu'"));
  }
}

}  // namespace
}  // namespace tac3d::cli
