#pragma once

// What `tac3d view` serves the viewer page besides its files (docs/viewer.md): a recording's
// or a dataset's frames by index, for the page's time slider, and a friction map's mesh.

#include <optional>
#include <string>
#include <vector>

#include "tac3d/runtime/sensor_stream.h"
#include "tac3d/scene/ply.h"
#include "tac3d/web/web_server.h"

namespace tac3d::cli {

/// The frames of a finished stream and, optionally, a friction map, answering the page's
/// GET /api/... requests:
/// - /api/frames: {"sn","source","count","t":[s...],"F":[[x,y,z]...],"M":[[...]...],"images"}
/// - /api/frame/N: frame N as the live stream's frame message (FrameToJson)
/// - /api/image/N: frame N's camera image as the live image message, with the tracker's markers
///   drawn on it when the stream gave them (a dataset's; a recording has none); 404 without one
/// - /api/friction-map: {"vertices":[x,y,z,...] (mm),"triangles":[i,j,k,...],"mu":[...]
///   (null unknown),"confidence":[...],"colors":[r,g,b,...] (0-255, the paper's bands),
///   "bands":{"unknown","low","medium","high"} (vertices per band)}; 404 without a map.
class ViewData {
 public:
  /// Reads every frame `stream` gives (as fast as it gives them), keeping each one's image
  /// downscaled to `image_width` px as JPEG, its markers drawn on it when the stream gives
  /// them. @throws Error if the stream fails.
  void LoadFrames(runtime::SensorStream& stream, const std::string& source, int image_width = 320);

  /// A friction map as `tac3d friction-map` writes it: map.ply, or the folder holding it.
  /// @throws Error naming the file if it is not a PLY with a per-vertex `mu`.
  void LoadFrictionMap(const std::string& dir_or_ply);

  /// The reply to an /api/ target, nullopt for 404. @throws Error on a malformed index.
  std::optional<WebReply> Handle(const std::string& target) const;

  long frames() const { return static_cast<long>(frames_.size()); }

 private:
  std::string source_;
  std::vector<TactileFrame> frames_;
  std::vector<std::string> images_;  // each frame's image message, "" without an image
  std::string friction_json_;        // "" without a map
};

}  // namespace tac3d::cli
