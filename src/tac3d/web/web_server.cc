#include "tac3d/web/web_server.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tac3d/util/error.h"

namespace tac3d {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

void WebServerOptions::Validate() const {
  const auto bad = [](const char* field, const std::string& bound) {
    throw Error(fmt::format("WebServerOptions::{}: {}", field, bound));
  };
  if (host.empty()) bad("host", "must not be empty");
  if (!(stream_hz > 0 && stream_hz <= 1000)) bad("stream_hz", fmt::format("{} not in (0, 1000]", stream_hz));
  if (!(image_hz >= 0 && image_hz <= 30)) bad("image_hz", fmt::format("{} not in [0, 30]", image_hz));
  if (image_width < 16 || image_width > 4096) bad("image_width", fmt::format("{} not in [16, 4096]", image_width));
  if (max_clients < 1 || max_clients > 10000) bad("max_clients", fmt::format("{} not in [1, 10000]", max_clients));
  if (!(stall_timeout_s > 0 && stall_timeout_s <= 600))
    bad("stall_timeout_s", fmt::format("{} not in (0, 600]", stall_timeout_s));
  std::error_code ec;
  if (root.empty() || !fs::is_directory(root, ec)) bad("root", fmt::format("'{}' is not a folder", root));
}

namespace {

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// The percent-decoded path, or nullopt on a bad escape.
std::optional<std::string> PercentDecode(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '%') {
      out.push_back(s[i]);
      continue;
    }
    if (i + 2 >= s.size()) return std::nullopt;
    const int hi = HexDigit(s[i + 1]), lo = HexDigit(s[i + 2]);
    if (hi < 0 || lo < 0) return std::nullopt;
    out.push_back(static_cast<char>(hi * 16 + lo));
    i += 2;
  }
  return out;
}

const char* ContentType(const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "application/javascript";
  if (ext == ".css") return "text/css";
  if (ext == ".png") return "image/png";
  if (ext == ".json") return "application/json";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

std::string Base64(const std::vector<uchar>& bytes) {
  static constexpr char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t a = bytes[i];
    const std::uint32_t b = i + 1 < bytes.size() ? bytes[i + 1] : 0;
    const std::uint32_t c = i + 2 < bytes.size() ? bytes[i + 2] : 0;
    const std::uint32_t v = (a << 16) | (b << 8) | c;
    out.push_back(kTable[(v >> 18) & 63]);
    out.push_back(kTable[(v >> 12) & 63]);
    out.push_back(i + 1 < bytes.size() ? kTable[(v >> 6) & 63] : '=');
    out.push_back(i + 2 < bytes.size() ? kTable[v & 63] : '=');
  }
  return out;
}

// A browser sends Origin with a WebSocket handshake; a page from another site (which could
// otherwise read the stream and send "zero" from the user's browser) has an Origin whose
// host differs from the Host it connected to. Clients that are not browsers send none.
bool SameOrigin(const http::request<http::string_body>& request) {
  const auto origin = request.find(http::field::origin);
  if (origin == request.end()) return true;
  const std::string value(origin->value());
  const size_t scheme = value.find("://");
  if (scheme == std::string::npos) return false;
  return value.substr(scheme + 3) == std::string(request[http::field::host]);
}

// An SN as a JSON string's contents: characters that would need escaping become '?'.
std::string JsonSafe(std::string s) {
  for (char& c : s) {
    if (c < 0x20 || c >= 0x7f || c == '"' || c == '\\') c = '?';
  }
  return s;
}

}  // namespace

std::string ImageToJson(const std::string& sn, std::int64_t index, const cv::Mat& image, int width,
                        const std::vector<ImageMarker>& markers) {
  const cv::Mat small = DrawCameraImage(image, markers, width);
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", small, jpeg, {cv::IMWRITE_JPEG_QUALITY, 70});
  return fmt::format("{{\"type\":\"image\",\"sn\":\"{}\",\"index\":{},\"w\":{},\"h\":{},\"jpeg\":\"{}\"}}",
                     JsonSafe(sn), index, small.cols, small.rows, Base64(jpeg));
}

std::string ResolveStaticPath(const std::string& root, const std::string& target) {
  std::string_view path(target);
  path = path.substr(0, path.find_first_of("?#"));
  if (path.empty() || path[0] != '/') return "";
  const std::optional<std::string> decoded = PercentDecode(path);
  if (!decoded) return "";
  if (decoded->find('\0') != std::string::npos || decoded->find('\\') != std::string::npos) return "";
  fs::path relative;
  std::stringstream segments(*decoded);
  std::string segment;
  while (std::getline(segments, segment, '/')) {
    if (segment == "..") return "";
    if (segment.empty() || segment == ".") continue;
    relative /= segment;
  }
  if (relative.empty() || decoded->back() == '/') relative /= "index.html";
  std::error_code ec;
  const fs::path canonical_root = fs::canonical(root, ec);
  if (ec) return "";
  const fs::path file = fs::canonical(canonical_root / relative, ec);
  if (ec || !fs::is_regular_file(file, ec)) return "";
  // The file must lie inside the root, also after symlinks are followed.
  const std::string prefix = canonical_root.string() + "/";
  if (file.string().compare(0, prefix.size(), prefix) != 0) return "";
  return file.string();
}

namespace internal {

class WsSession;

class WebServerImpl {
 public:
  explicit WebServerImpl(const WebServerOptions& options);
  ~WebServerImpl();

  void Publish(const TactileFrame& frame, const cv::Mat& image, const MarkerObservation* markers);
  void Register(const std::shared_ptr<WsSession>& session);
  void Unregister(const WsSession* session);
  void Accept();
  void Tick();
  // A client's "zero" (every sensor) or "zero SN".
  void RequestZero(const std::string& message);
  bool TakeZeroRequest(const std::string& sn);

  const WebServerOptions options_;
  net::io_context io_{1};
  tcp::acceptor acceptor_{io_};
  net::steady_timer timer_{io_};
  std::thread thread_;
  std::uint16_t port_ = 0;

  std::atomic<int> clients_{0};
  std::atomic<std::int64_t> frames_published_{0}, messages_sent_{0}, sends_skipped_{0},
      clients_dropped_{0}, http_requests_{0}, bad_requests_{0};

 private:
  // One sensor's latest frame, overwritten by Publish; the server thread takes it at its pace.
  struct Slot {
    TactileFrame frame;
    std::uint64_t seq = 0;
    double fps = 0.0;
    Clock::time_point last_publish{};
    cv::Mat image;
    std::vector<ImageMarker> markers;  // the image's, drawn on it
    std::int64_t image_index = 0;
    std::uint64_t image_seq = 0;
    Clock::time_point last_image{};
    // Server-thread side: what was last sent.
    std::uint64_t sent_seq = 0, sent_image_seq = 0;
  };
  std::mutex mutex_;
  std::map<std::string, Slot, std::less<>> slots_;
  // Zero requests: "zero" bumps the generation every sensor compares with the one it took
  // last; "zero SN" marks that sensor. Under mutex_.
  std::uint64_t zero_all_generation_ = 0;
  std::map<std::string, std::uint64_t, std::less<>> zero_taken_generation_;
  std::set<std::string, std::less<>> zero_one_;

  std::vector<std::shared_ptr<WsSession>> sessions_;  // server thread only
  // The last message of each key ("frame:SN", "image:SN"), which a new client gets at once
  // (a source that ended still shows its last frame). Server thread only.
  std::map<std::string, std::shared_ptr<const std::string>> last_messages_;
  TactileFrame scratch_frame_;                        // server thread only
  cv::Mat scratch_image_;                             // server thread only
  std::vector<ImageMarker> scratch_markers_;          // server thread only
};

// One WebSocket client. Holds at most one message in flight and, per key (a sensor's frame
// or image), one newer message waiting; a newer one replaces the waiting one.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(beast::tcp_stream&& stream, WebServerImpl& server) : ws_(std::move(stream)), server_(server) {}

  void Run(http::request<http::string_body> request) {
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(4096);
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) {
      if (ec) {
        ++self->server_.bad_requests_;
        return;
      }
      self->open_ = true;
      self->server_.Register(self);
      self->DoRead();
    });
  }

  void Send(const std::string& key, std::shared_ptr<const std::string> message) {
    if (!open_) return;
    auto& waiting = waiting_[key];
    if (waiting) ++server_.sends_skipped_;
    waiting = std::move(message);
    if (!writing_) WriteNext();
  }

  bool Stalled(Clock::time_point now) const {
    return writing_ && now - write_started_ > std::chrono::duration<double>(server_.options_.stall_timeout_s);
  }

  void Drop() {
    open_ = false;
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().close(ec);
  }

 private:
  void DoRead() {
    ws_.async_read(read_buffer_, [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec) return self->Close();
      const std::string message = beast::buffers_to_string(self->read_buffer_.data());
      self->read_buffer_.consume(self->read_buffer_.size());
      self->server_.RequestZero(message);
      self->DoRead();
    });
  }

  void WriteNext() {
    for (auto& [key, message] : waiting_) {
      if (!message) continue;
      in_flight_ = std::move(message);
      message.reset();
      writing_ = true;
      write_started_ = Clock::now();
      ws_.text(true);
      ws_.async_write(net::buffer(*in_flight_), [self = shared_from_this()](beast::error_code ec, size_t) {
        self->writing_ = false;
        self->in_flight_.reset();
        if (ec) return self->Close();
        ++self->server_.messages_sent_;
        if (self->open_) self->WriteNext();
      });
      return;
    }
  }

  void Close() {
    if (closed_) return;
    closed_ = true;
    open_ = false;
    server_.Unregister(this);
  }

  websocket::stream<beast::tcp_stream> ws_;
  WebServerImpl& server_;
  beast::flat_buffer read_buffer_;
  std::map<std::string, std::shared_ptr<const std::string>> waiting_;
  std::shared_ptr<const std::string> in_flight_;
  bool writing_ = false, open_ = false, closed_ = false;
  Clock::time_point write_started_;
};

// One HTTP connection: static files from the root, or the upgrade to /ws.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, WebServerImpl& server) : stream_(std::move(socket)), server_(server) {}

  void DoRead() {
    parser_.emplace();
    parser_->header_limit(8 * 1024);
    parser_->body_limit(8 * 1024);
    stream_.expires_after(std::chrono::seconds(10));
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, size_t) {
      self->OnRead(ec);
    });
  }

 private:
  void OnRead(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == net::error::eof) return Shutdown();
    if (ec) {
      ++server_.bad_requests_;
      if (ec == beast::error::timeout || ec == net::error::operation_aborted) return Shutdown();
      return Respond(http::status::bad_request, "malformed request\n", "text/plain", 11, false);
    }
    http::request<http::string_body> request = parser_->release();
    ++server_.http_requests_;
    const std::string target(request.target());
    if (websocket::is_upgrade(request)) {
      if (target != "/ws") return Respond(http::status::not_found, "not found\n", "text/plain", request.version(), false);
      if (!SameOrigin(request))
        return Respond(http::status::forbidden, "cross-origin WebSocket refused\n", "text/plain", request.version(), false);
      if (server_.clients_ >= server_.options_.max_clients)
        return Respond(http::status::service_unavailable, "too many clients\n", "text/plain", request.version(), false);
      std::make_shared<WsSession>(std::move(stream_), server_)->Run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head)
      return Respond(http::status::method_not_allowed, "GET or HEAD only\n", "text/plain", request.version(), false);
    const bool head = request.method() == http::verb::head;
    if (target.rfind("/api/", 0) == 0) return RespondApi(target, head, request.version(), request.keep_alive());
    const std::string file = ResolveStaticPath(server_.options_.root, target);
    std::string body;
    if (!file.empty()) {
      std::ifstream in(file, std::ios::binary);
      std::ostringstream contents;
      contents << in.rdbuf();
      if (in.good() || in.eof()) body = contents.str();
    }
    if (file.empty()) return Respond(http::status::not_found, "not found\n", "text/plain", request.version(), request.keep_alive());
    Respond(http::status::ok, head ? std::string() : std::move(body), ContentType(file), request.version(),
            request.keep_alive());
  }

  void RespondApi(const std::string& target, bool head, unsigned version, bool keep_alive) {
    std::optional<WebReply> reply;
    try {
      if (server_.options_.api) reply = server_.options_.api(target);
    } catch (const Error& e) {
      return Respond(http::status::bad_request, std::string(e.what()) + "\n", "text/plain", version, keep_alive);
    }
    if (!reply) return Respond(http::status::not_found, "not found\n", "text/plain", version, keep_alive);
    Respond(http::status::ok, head ? std::string() : std::move(reply->body), reply->content_type.c_str(), version,
            keep_alive);
  }

  void Respond(http::status status, std::string body, const char* type, unsigned version, bool keep_alive) {
    auto response = std::make_shared<http::response<http::string_body>>(status, version);
    response->set(http::field::server, "tac3d");
    response->set(http::field::content_type, type);
    response->set(http::field::cache_control, "no-store");
    response->keep_alive(keep_alive);
    response->body() = std::move(body);
    response->prepare_payload();
    http::async_write(stream_, *response, [self = shared_from_this(), response](beast::error_code ec, size_t) {
      if (ec || !response->keep_alive()) return self->Shutdown();
      self->DoRead();
    });
  }

  void Shutdown() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  beast::tcp_stream stream_;
  WebServerImpl& server_;
  beast::flat_buffer buffer_{16 * 1024};
  std::optional<http::request_parser<http::string_body>> parser_;
};

WebServerImpl::WebServerImpl(const WebServerOptions& options) : options_(options) {
  options_.Validate();
  beast::error_code ec;
  const net::ip::address address = net::ip::make_address(options_.host, ec);
  if (ec) throw Error(fmt::format("--web: '{}' is not an IP address", options_.host));
  const tcp::endpoint endpoint(address, options_.port);
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw Error(fmt::format("--web: cannot listen on {}:{}: {}", options_.host, options_.port, ec.message()));
  port_ = acceptor_.local_endpoint().port();
  Accept();
  Tick();
  thread_ = std::thread([this] {
    for (;;) {
      try {
        io_.run();
        return;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "web server: %s\n", e.what());
      }
    }
  });
}

WebServerImpl::~WebServerImpl() {
  io_.stop();
  if (thread_.joinable()) thread_.join();
}

void WebServerImpl::Accept() {
  acceptor_.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (!ec) {
      socket.set_option(tcp::no_delay(true), ec);
      std::make_shared<HttpSession>(std::move(socket), *this)->DoRead();
    }
    if (acceptor_.is_open()) Accept();
  });
}

void WebServerImpl::Register(const std::shared_ptr<WsSession>& session) {
  sessions_.push_back(session);
  clients_ = static_cast<int>(sessions_.size());
  for (const auto& [key, message] : last_messages_) session->Send(key, message);
}

void WebServerImpl::Unregister(const WsSession* session) {
  std::erase_if(sessions_, [session](const auto& s) { return s.get() == session; });
  clients_ = static_cast<int>(sessions_.size());
}

void WebServerImpl::RequestZero(const std::string& message) {
  std::lock_guard lock(mutex_);
  if (message == "zero") {
    ++zero_all_generation_;
  } else if (message.rfind("zero ", 0) == 0 && slots_.count(message.substr(5)) > 0) {
    // Only published SNs: a client cannot grow the set without bound.
    zero_one_.insert(message.substr(5));
  }
}

bool WebServerImpl::TakeZeroRequest(const std::string& sn) {
  std::lock_guard lock(mutex_);
  bool requested = zero_one_.erase(sn) > 0;
  auto taken = zero_taken_generation_.find(sn);
  if (taken == zero_taken_generation_.end()) taken = zero_taken_generation_.emplace(sn, 0).first;
  if (taken->second != zero_all_generation_) {
    taken->second = zero_all_generation_;
    requested = true;
  }
  return requested;
}

void WebServerImpl::Publish(const TactileFrame& frame, const cv::Mat& image, const MarkerObservation* markers) {
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(mutex_);
  auto it = slots_.find(frame.sn);
  if (it == slots_.end()) it = slots_.emplace(frame.sn, Slot{}).first;
  Slot& slot = it->second;
  slot.frame = frame;  // same sizes as last time: no allocation
  ++slot.seq;
  if (slot.last_publish != Clock::time_point{}) {
    const double dt = std::chrono::duration<double>(now - slot.last_publish).count();
    if (dt > 0) slot.fps = slot.fps == 0 ? 1.0 / dt : 0.9 * slot.fps + 0.1 / dt;
  }
  slot.last_publish = now;
  const bool image_due = options_.image_hz > 0 && clients_ > 0 && !image.empty() &&
                         now - slot.last_image >= std::chrono::duration<double>(1.0 / options_.image_hz);
  if (image_due) {
    image.copyTo(slot.image);
    // At the image's rate only; the slot's storage is reused.
    if (markers != nullptr) {
      ImageMarkersOf(*markers, slot.markers);
    } else {
      slot.markers.clear();
    }
    slot.image_index = frame.index;
    ++slot.image_seq;
    slot.last_image = now;
  }
  ++frames_published_;
}

void WebServerImpl::Tick() {
  timer_.expires_after(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.stream_hz)));
  timer_.async_wait([this](beast::error_code ec) {
    if (ec) return;
    const Clock::time_point now = Clock::now();
    for (const auto& session : std::vector(sessions_)) {
      if (session->Stalled(now)) {
        ++clients_dropped_;
        session->Drop();
      }
    }
    if (!sessions_.empty()) {
      std::vector<std::string> sns;
      {
        std::lock_guard lock(mutex_);
        for (const auto& [sn, slot] : slots_) sns.push_back(sn);
      }
      for (const std::string& sn : sns) {
        std::shared_ptr<const std::string> frame_message, image_message;
        double fps = 0;
        bool have_image = false;
        std::int64_t image_index = 0;
        {
          std::lock_guard lock(mutex_);
          Slot& slot = slots_.find(sn)->second;
          if (slot.seq != slot.sent_seq) {
            scratch_frame_ = slot.frame;
            fps = slot.fps;
            slot.sent_seq = slot.seq;
            frame_message = std::make_shared<const std::string>();
          }
          if (slot.image_seq != slot.sent_image_seq) {
            slot.image.copyTo(scratch_image_);
            scratch_markers_ = slot.markers;
            image_index = slot.image_index;
            slot.sent_image_seq = slot.image_seq;
            have_image = true;
          }
        }
        // Serialised outside the lock: Publish waits at most for the copies above.
        if (frame_message) frame_message = std::make_shared<const std::string>(FrameToJson(scratch_frame_, fps));
        if (have_image) {
          image_message = std::make_shared<const std::string>(
              ImageToJson(sn, image_index, scratch_image_, options_.image_width, scratch_markers_));
        }
        if (frame_message) last_messages_["frame:" + sn] = frame_message;
        if (image_message) last_messages_["image:" + sn] = image_message;
        for (const auto& session : std::vector(sessions_)) {
          if (frame_message) session->Send("frame:" + sn, frame_message);
          if (image_message) session->Send("image:" + sn, image_message);
        }
      }
    }
    Tick();
  });
}

}  // namespace internal

WebServer::WebServer(const WebServerOptions& options) : impl_(std::make_unique<internal::WebServerImpl>(options)) {}
WebServer::~WebServer() = default;

std::uint16_t WebServer::port() const { return impl_->port_; }

void WebServer::Publish(const TactileFrame& frame, const cv::Mat& image, const MarkerObservation* markers) {
  impl_->Publish(frame, image, markers);
}

bool WebServer::TakeZeroRequest(const std::string& sn) { return impl_->TakeZeroRequest(sn); }

WebServerStats WebServer::stats() const {
  return {.frames_published = impl_->frames_published_,
          .messages_sent = impl_->messages_sent_,
          .sends_skipped = impl_->sends_skipped_,
          .clients_dropped = impl_->clients_dropped_,
          .http_requests = impl_->http_requests_,
          .bad_requests = impl_->bad_requests_,
          .clients = impl_->clients_};
}

}  // namespace tac3d
