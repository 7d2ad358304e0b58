// Image to TactileFrame with the live viewer's server off (/0), on with one browser-like
// client reading everything (/1), and on with that client plus one stalled client that never
// reads (/2): the viewer must cost the pipeline nothing measurable (within 5%).
// Publish (a copy into the latest-frame slot, and the image and its markers at image_hz) is
// inside the timed loop; the server's thread serialises, draws and sends at stream_hz = 30.
// Run: build/bin/bench_web --benchmark_repetitions=20 --benchmark_enable_random_interleaving=true
//        --benchmark_report_aggregates_only=true  (interleaved: the machine's load drifts)
#include <atomic>
#include <cmath>
#include <filesystem>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <benchmark/benchmark.h>

#include "tac3d/design/light_path_design.h"
#include "tac3d/force/synthetic_compliance.h"
#include "tac3d/pipeline/pipeline.h"
#include "tac3d/twin/camera_renderer.h"
#include "tac3d/web/test_websocket_client.h"
#include "tac3d/web/web_server.h"

namespace tac3d {
namespace {

// A pipeline past its reference and 16 twin frames of a press coming and going.
struct Press {
  SensorConfig config = DefaultSensorConfig();
  Pipeline pipeline;
  std::vector<Frame> frames;

  Press() : pipeline(config, CalcSyntheticCompliance({}).h, config.MarkerPositions(), Options()) {
    const std::vector<Eigen::Vector3d> rest = config.MarkerPositions();
    const MarkerImageRenderer renderer(config);
    for (int k = 0; k < 16; ++k) {
      std::vector<Eigen::Vector3d> markers = rest;
      const double depth_mm = 0.6 * (0.5 - 0.5 * std::cos(2 * M_PI * k / 16.0));
      for (auto& p : markers) p.z() -= depth_mm * std::exp(-p.head<2>().squaredNorm() / 18.0);
      frames.push_back({renderer.Render(markers, k), 0.0, k});
    }
    TactileFrame out;
    for (int k = 0; k < 2; ++k) pipeline.Process({renderer.Render(rest, 100 + k), 0.0, k}, out);
  }
  static PipelineOptions Options() {
    PipelineOptions options;
    options.reference_frames = 2;
    return options;
  }
};

// A WebSocket client on its own thread that reads every message until it is destroyed.
class ReadingClient {
 public:
  explicit ReadingClient(std::uint16_t port) : client_(port, 0.0) {
    thread_ = std::thread([this] {
      try {
        for (;;) {
          client_.Read();
          ++messages_;
        }
      } catch (const std::runtime_error&) {
      }
    });
  }
  ~ReadingClient() {
    client_.Disconnect();
    thread_.join();
  }
  long messages() const { return messages_; }

 private:
  testing::WebSocketClient client_;
  std::thread thread_;
  std::atomic<long> messages_{0};
};

// Completes the WebSocket handshake and never reads again.
int StalledClient(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  int small = 4096;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    const std::string request =
        "GET /ws HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
    (void)!::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  }
  return fd;
}

void BM_ImageToTactileFrameWithViewer(benchmark::State& state) {
  Press press;
  const std::string root = std::filesystem::temp_directory_path() / "tac3d_bench_web";
  std::filesystem::create_directories(root);
  std::unique_ptr<WebServer> server;
  std::unique_ptr<ReadingClient> client;
  int stalled = -1;
  if (state.range(0) >= 1) {
    WebServerOptions options;
    options.port = 0;
    options.root = root;
    options.stall_timeout_s = 600;  // keep the stalled client for the whole run
    server = std::make_unique<WebServer>(options);
    client = std::make_unique<ReadingClient>(server->port());
    if (state.range(0) == 2) stalled = StalledClient(server->port());
    while (server->stats().clients < state.range(0)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  TactileFrame out;
  size_t k = 0;
  for (auto _ : state) {
    const Frame& frame = press.frames[k++ % press.frames.size()];
    press.pipeline.Process(frame, out);
    if (server) server->Publish(out, frame.image, &press.pipeline.observation());
    benchmark::DoNotOptimize(out.resultant_force_n);
  }
  if (server) {
    const WebServerStats s = server->stats();
    state.counters["messages_sent"] = static_cast<double>(s.messages_sent);
    state.counters["clients"] = s.clients;
  }
  client.reset();
  server.reset();
  if (stalled >= 0) ::close(stalled);
}
BENCHMARK(BM_ImageToTactileFrameWithViewer)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->MinTime(0.5);

}  // namespace
}  // namespace tac3d

BENCHMARK_MAIN();
