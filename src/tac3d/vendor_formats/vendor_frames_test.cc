#include "tac3d/vendor_formats/vendor_frames.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tac3d/record/recording.h"
#include "tac3d/testing/testing.h"
#include "tac3d/util/error.h"
#include "tac3d/vendor_formats/test_vendor_folder.h"

namespace tac3d {
namespace {

// Frames from a vendor recording, through a tac3d recording file and back: the vendor's fields
// bit for bit.
void ExpectVendorRoundTrip(const VendorRecording& vendor) {
  const std::vector<TactileFrame> frames = FramesOfVendorRecording(vendor);
  ASSERT_EQ(static_cast<std::int64_t>(frames.size()), vendor.frames());
  const std::string path = testing::MakeTempDir("frames") + "/recording.tac3drec";
  {
    RecordingWriter writer(path);
    for (const TactileFrame& frame : frames) writer.Write(frame);
  }
  std::vector<TactileFrame> read;
  RecordingReader reader(path);
  while (const std::optional<RecordedFrame> r = reader.Next()) read.push_back(r->frame);
  EXPECT_EQ(reader.status(), RecordingStatus::kComplete);
  EXPECT_EQ(read, frames);
  EXPECT_EQ(VendorRecordingOfFrames(read), vendor);
}

TEST(VendorFrames, ASmallRecordingRoundTripsThroughATac3dRecording) {
  VendorRecording r;
  r.serial_number = "AD2-0065L";
  const auto doubles = [](std::vector<std::int64_t> shape, double first) {
    NpyArray a;
    a.shape = std::move(shape);
    std::vector<double> v(static_cast<std::size_t>(a.elements()));
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = first - 0.37 * static_cast<double>(i);
    a.data.assign(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
    return a;
  };
  r.positions = doubles({3, 4, 3}, 9.0);
  r.displacements = doubles({3, 4, 3}, 0.1);
  r.forces = doubles({3, 4, 3}, -0.01);
  r.resultant_force = doubles({3, 1, 3}, -5.37);
  r.resultant_moment = doubles({3, 1, 3}, 2.0);
  r.send_timestamp = doubles({3}, 1455.025456);
  r.index.type = NpyType::kInt64;
  r.index.shape = {3};
  const std::int64_t index[] = {7, 8, 10};
  r.index.data.assign(reinterpret_cast<const char*>(index), sizeof(index));
  const std::vector<TactileFrame> frames = FramesOfVendorRecording(r);
  EXPECT_EQ(frames[2].index, 10);
  EXPECT_EQ(frames[1].rows, 2);
  EXPECT_EQ(frames[1].positions_mm[3], Eigen::Vector3d(9.0 - 0.37 * 21, 9.0 - 0.37 * 22, 9.0 - 0.37 * 23));
  EXPECT_EQ(frames[0].resultant_force_n.z(), -5.37 - 0.37 * 2);
  EXPECT_EQ(frames[0].normals[0], Eigen::Vector3d::Zero());
  ExpectVendorRoundTrip(r);

  r.positions = doubles({3, 5, 3}, 0.0);
  r.displacements = r.forces = r.positions;
  EXPECT_THROW(FramesOfVendorRecording(r), Error);  // 5 markers: no square grid
  std::vector<TactileFrame> mixed = frames;
  mixed[1].sn = "other";
  EXPECT_THROW(VendorRecordingOfFrames(mixed), Error);
  EXPECT_THROW(VendorRecordingOfFrames({}), Error);
}

// A NaN in a vendor .npy was imported as a valid marker (and crashed the friction map's
// reconstruction): such a marker is lost in its frame; frame 0, the reference, must be whole.
TEST(VendorFrames, AMarkerThatIsNotANumberIsLostAndTheReferenceMustBeWhole) {
  std::vector<TactileFrame> frames(3, TactileFrame::Sized(2, 2));
  for (int k = 0; k < 3; ++k) {
    frames[k].sn = "NAN-1";
    frames[k].index = k;
    frames[k].timestamp_s = 0.1 * k;
    for (int i = 0; i < 4; ++i) frames[k].positions_mm[i] = Eigen::Vector3d(i % 2, i / 2, 0.01 * k);
  }
  VendorRecording r = VendorRecordingOfFrames(frames);
  double* displacements = reinterpret_cast<double*>(r.displacements.data.data());
  displacements[(2 * 4 + 1) * 3 + 2] = std::numeric_limits<double>::quiet_NaN();  // frame 2, marker 1, z
  const VendorFrames vendor(r);
  const TactileFrame lost = vendor.Frame(2);
  EXPECT_FALSE(lost.valid[1]);
  EXPECT_TRUE(lost.valid[0] && lost.valid[2] && lost.valid[3]);
  EXPECT_TRUE(lost.has(FrameFlag::kMarkersLost));
  EXPECT_NO_THROW(lost.Validate());
  EXPECT_TRUE(vendor.Frame(1).valid[1]);
  displacements[1 * 3 + 2] = std::numeric_limits<double>::infinity();  // frame 0, marker 1
  EXPECT_THAT([&] { VendorFrames{r}; },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr(
                  "frame 0, the reference, has a marker (1) whose position, displacement or force is not a finite")));
}

TEST(VendorFrames, RealRecordingsRoundTripThroughATac3dRecording) {
  TAC3D_REQUIRE_REALDATA(realdata);
  ExpectVendorRoundTrip(ReadVendorRecording(realdata + "/tac3d/HDL1-0001/recording/Tac3D_Record_20241227_161029"));
  ExpectVendorRoundTrip(ReadVendorRecording(realdata + "/tac3d/YA1-007/recording/example"));
}

}  // namespace
}  // namespace tac3d
