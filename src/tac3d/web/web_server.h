#pragma once

// The live viewer's server (docs/viewer.md): HTTP for the page's static files and a WebSocket
// endpoint, /ws, streaming the latest frame of each sensor as JSON. Boost.Beast stays in
// web_server.cc behind a pimpl.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "tac3d/frame/tactile_frame.h"

namespace tac3d {

struct MarkerObservation;  // tac3d/tracking/marker_tracker.h
struct GridObservation;    // tac3d/tracking/grid_tracker.h

/// A marker as the viewer draws it on the camera image.
struct ImageMarker {
  Eigen::Vector2f uv_px = Eigen::Vector2f::Zero();  ///< in the full-size camera image, px
  /// Measured in this frame; else lost, and drawn where the tracker takes it to be.
  bool tracked = false;
};

/// A reply to an HTTP GET the server's `api` handler answered.
struct WebReply {
  std::string body;
  std::string content_type = "application/json";
};

/// Answers GET (and HEAD) requests whose target starts with "/api/", on the server's thread:
/// the target (path and query) in, the reply out, or nullopt for 404. An Error it throws is a
/// 400 with the message.
using WebApiHandler = std::function<std::optional<WebReply>(const std::string& target)>;

/// How the viewer's server listens and streams. Defaults bind loopback only.
struct WebServerOptions {
  std::string host = "127.0.0.1";  ///< address to bind; "0.0.0.0" exposes it to the network
  std::uint16_t port = 8080;       ///< TCP port; 0 picks a free one (see WebServer::port())
  std::string root;                ///< the one folder static files are served from (must exist)
  double stream_hz = 30.0;         ///< frames sent to each client per second, (0, 1000]
  double image_hz = 4.0;           ///< camera images sent per second, [0, 30]; 0 never
  int image_width = 320;           ///< width the image is downscaled to, [16, 4096] px
  int max_clients = 64;            ///< WebSocket clients at once, [1, 10000]; more are refused
  /// A client whose send has not completed for this long is disconnected, (0, 600] s.
  double stall_timeout_s = 5.0;
  /// Dynamic data under /api/ (`tac3d view`: a recording's frames by index); empty: 404.
  WebApiHandler api;

  /// @throws Error naming the field and its bound, or a root that is not a folder.
  void Validate() const;
};

/// Counters of what the server did (for tests and the run's closing line).
struct WebServerStats {
  std::int64_t frames_published = 0;  ///< Publish calls
  std::int64_t messages_sent = 0;     ///< frame messages whose send completed
  std::int64_t sends_skipped = 0;     ///< a client still busy with an earlier message
  std::int64_t clients_dropped = 0;   ///< clients disconnected for stalling
  std::int64_t http_requests = 0;     ///< HTTP requests answered (any status)
  std::int64_t bad_requests = 0;      ///< connections closed on malformed input
  int clients = 0;                    ///< WebSocket clients connected now
};

namespace internal {
class WebServerImpl;
}

/// An HTTP + WebSocket server on its own thread. Publish() only copies the frame into a
/// latest-frame slot per sensor (SN) under a short lock; the server's thread sends each
/// client the newest frame at `stream_hz` and skips a client whose previous message is still
/// in flight, so a slow or stalled browser never holds up the caller.
class WebServer {
 public:
  /// Binds and starts serving. @throws Error on bad options or when the address cannot be bound.
  explicit WebServer(const WebServerOptions& options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  /// The port bound (the one chosen when options.port was 0).
  std::uint16_t port() const;

  /// Makes `frame` its sensor's latest frame. `image` (CV_8UC1 or empty) is copied only when
  /// an image is due (image_hz) and a client is connected, and so are the pixels of `markers`
  /// (the tracker's in `image`, or null), which are drawn on it (DrawCameraImage). Never
  /// blocks on the network.
  void Publish(const TactileFrame& frame, const cv::Mat& image = cv::Mat(),
               const MarkerObservation* markers = nullptr);

  /// True once for each zero request for sensor `sn` a client sent since the last call with
  /// this `sn`: the message "zero" asks every sensor, "zero SN" the one sensor SN (a sensor
  /// that has published; others are ignored).
  bool TakeZeroRequest(const std::string& sn);

  WebServerStats stats() const;

 private:
  std::unique_ptr<internal::WebServerImpl> impl_;
};

/// The frame as the compact JSON message the page reads (docs/viewer.md): {"type":"frame",
/// "sn", "index", "t", "rows", "cols", "p", "d", "f", "n" (flat x,y,z arrays, 3 decimals,
/// null for an invalid marker's values), "valid", "contact" (0/1 strings), "F", "M", "flags",
/// "init", "slip", "slip_fraction", "mu", "mu_sigma", "slip_margin", "slip_margin_sigma",
/// "least_normal_force_n", "fps"} (null for NaN).
std::string FrameToJson(const TactileFrame& frame, double fps);

/// Both halves' markers of an observation into `markers` (its storage reused): each valid one
/// tracked at its centroid (HalfObservation::uv), each other one lost at the tracker's estimate
/// (HalfObservation::estimate_uv; left out where there is none).
void ImageMarkersOf(const MarkerObservation& observation, std::vector<ImageMarker>& markers);
/// One view's markers (a half, or a single-view sensor's image) appended to `markers`, as
/// ImageMarkersOf.
void AppendImageMarkers(const GridObservation& view, std::vector<ImageMarker>& markers);

/// The camera image as the page shows it: downscaled to at most `width` px wide (INTER_AREA;
/// never enlarged), CV_8UC1 without markers; with markers, CV_8UC3 (BGR) with each tracked
/// marker a green ring and each lost one a red cross, 4 camera px in radius (at least 2 px).
/// @pre image is CV_8UC1 and not empty, width > 0.
cv::Mat DrawCameraImage(const cv::Mat& image, const std::vector<ImageMarker>& markers, int width);

/// DrawCameraImage's picture of one view at full size, with each tracked marker's
/// displacement from its reference position (`reference.estimate_uv`) as a yellow arrow of true
/// length (none under half a pixel): a single-view track's overlay.
/// @pre image is CV_8UC1 and not empty; `view` and `reference` have the same markers.
cv::Mat DrawDisplacementImage(const cv::Mat& image, const GridObservation& view, const GridObservation& reference);

/// The camera image as the page's message: {"type":"image","sn","index","w","h","jpeg"
/// (base64)}, DrawCameraImage's picture of `image` and `markers`. @pre as DrawCameraImage.
std::string ImageToJson(const std::string& sn, std::int64_t index, const cv::Mat& image, int width,
                        const std::vector<ImageMarker>& markers = {});

/// The file under `root` a request target names, or "" when it names none: the path part
/// (query dropped) percent-decoded, "/" as index.html; "" for "..", a NUL, a backslash, a bad
/// escape, or a file whose canonical path leaves the canonical root (symlinks too).
std::string ResolveStaticPath(const std::string& root, const std::string& target);

}  // namespace tac3d
