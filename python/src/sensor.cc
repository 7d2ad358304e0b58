// tac3d.Sensor: the vendor PyTac3D client's interface over tac3d::Client.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "arrays.h"
#include "bindings.h"
#include "tac3d/protocol/client.h"
#include "tac3d/util/seconds_since.h"

namespace tac3d::python {
namespace {

constexpr double kReceiveSliceS = 0.05;  // how long the thread waits in Client::Receive at once
constexpr const char* kAny = "any";

// A decoded item as the vendor client gives it: mat -> float64 height x width (the decoded
// matrix moved into the array, no copy), f64 -> float, i32 -> int, img -> uint8 array.
py::object FieldToPython(DecodedField&& field) {
  switch (field.type) {
    case FieldType::kMat: {
      RowMajorMatrixXd* owned = nullptr;
      py::capsule base = OwnedCapsule(std::move(field.matrix), &owned);
      return py::array_t<double>({owned->rows(), owned->cols()}, owned->data(), base);
    }
    case FieldType::kF64:
      return py::float_(field.matrix(0, 0));
    case FieldType::kI32:
      return py::int_(static_cast<long long>(field.matrix(0, 0)));
    case FieldType::kImg:
      return ImageArray(field.image);
  }
  return py::none();
}

bool Initializing(const DecodedFrame& frame) {
  const DecodedField* progress = frame.Find(kFieldInitializeProgress);
  return progress != nullptr && progress->matrix(0, 0) != 100.0;
}

}  // namespace

/// The receiving side. A thread owns the Client's receive loop; frames become dicts under the
/// GIL, go to the bounded per-SN queues (and "any") and to the callback. Commands take the
/// client's mutex, which the thread holds only inside Receive (at most kReceiveSliceS).
class Sensor {
 public:
  Sensor(py::object callback,
         int port,
         int max_queue,
         py::object param,
         const std::string& bind_address,
         double frame_timeout_s,
         bool drop_initializing)
      : callback_(std::move(callback)),
        param_(std::move(param)),
        max_queue_(max_queue),
        drop_initializing_(drop_initializing) {
    if (port < 0 || port > 65535)
      throw Error(fmt::format("Sensor: port = {} must be 0-65535", port));
    if (max_queue < 1) throw Error(fmt::format("Sensor: maxQSize = {} must be >= 1", max_queue));
    if (!callback_.is_none() && !PyCallable_Check(callback_.ptr())) {
      throw Error("Sensor: recvCallback must be callable (frame, param) or None");
    }
    ClientOptions options;
    options.bind_address = bind_address;
    options.port = static_cast<std::uint16_t>(port);
    options.assembler.timeout_s = frame_timeout_s;
    client_ = std::make_unique<Client>(options);
    port_ = client_->local_endpoint().port;
    thread_ = std::thread([this] { Loop(); });
    Registry().insert(this);
  }

  ~Sensor() { Close(); }

  /// Stops the thread and releases the port. GIL held by the caller.
  void Close() {
    Registry().erase(this);
    if (thread_.joinable()) {
      stop_ = true;
      py::gil_scoped_release release;
      thread_.join();
    }
    {
      py::gil_scoped_release release;  // a Send in another thread may hold the client
      std::lock_guard lock(client_mutex_);
      client_.reset();
    }
    queues_.clear();
  }

  py::object GetFrame(const std::string& sn) {
    auto it = queues_.find(sn);
    if (it == queues_.end() || it->second.empty()) return py::none();
    py::object frame = std::move(it->second.front());
    it->second.pop_front();
    return frame;
  }

  bool WaitForFrame(const std::string& sn, std::optional<double> timeout_s) {
    if (timeout_s && !(*timeout_s >= 0)) {
      throw Error(fmt::format("Sensor.waitForFrame: timeout = {} must be >= 0 s (None: no timeout)",
                              *timeout_s));
    }
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
      {
        py::gil_scoped_release release;
        std::unique_lock lock(state_mutex_);
        const auto seen = [&] { return sn == kAny ? !seen_.empty() : seen_.count(sn) > 0; };
        // Wake up every 0.1 s to let Python handle Ctrl-C.
        if (cv_.wait_for(lock, std::chrono::milliseconds(100), seen)) return true;
      }
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      const double waited = SecondsSince(start);
      if (timeout_s && waited >= *timeout_s) return false;
    }
  }

  bool Send(const std::string& sn, SensorCommand command) {
    std::optional<Endpoint> address;
    {
      std::lock_guard lock(state_mutex_);
      if (auto it = addresses_.find(sn); it != addresses_.end()) address = it->second;
    }
    if (!address) return false;
    py::gil_scoped_release release;
    ++waiting_senders_;
    std::lock_guard lock(client_mutex_);
    --waiting_senders_;
    if (!client_) throw Error("Sensor: closed");
    client_->SendCommand(*address, command);
    return true;
  }

  int port() const { return port_; }
  py::dict Stats() {
    std::lock_guard lock(client_mutex_);
    py::dict drops;
    if (client_) {
      const DropCounts& counts = client_->drops();
      for (int r = 0; r < kNumDropReasons; ++r) {
        drops[DropReasonName(static_cast<DropReason>(r))] = counts.counts[r];
      }
    }
    py::dict out;
    out["frames"] = frames_.load();
    out["initializing_dropped"] = initializing_dropped_.load();
    out["drops"] = drops;
    return out;
  }

  static std::set<Sensor*>& Registry() {
    static std::set<Sensor*> registry;  // guarded by the GIL
    return registry;
  }

 private:
  void Loop() {
    while (!stop_) {
      std::optional<ReceivedFrame> received;
      try {
        std::lock_guard lock(client_mutex_);
        received = client_->Receive(kReceiveSliceS);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "tac3d.Sensor: %s\n", e.what());
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        continue;
      }
      // std::mutex is not fair: let a waiting Send have the client before the next Receive.
      while (waiting_senders_ > 0 && !stop_)
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      if (!received) continue;
      {
        std::lock_guard lock(state_mutex_);
        addresses_[received->frame.sn] = received->sender;
      }
      if (drop_initializing_ && Initializing(received->frame)) {
        ++initializing_dropped_;
        continue;
      }
      Deliver(std::move(*received));
    }
  }

  // Thread side: builds the dict, queues it and calls back, with the GIL.
  void Deliver(ReceivedFrame&& received) {
    py::gil_scoped_acquire gil;
    const std::string sn = received.frame.sn;
    try {
      py::dict frame;
      frame["SN"] = sn;
      frame["index"] = received.frame.index;
      frame["sendTimestamp"] = received.frame.timestamp_s;
      frame["recvTimestamp"] = received.receive_time_s;
      frame["message"] = received.frame.msg;
      for (auto& [name, field] : received.frame.fields)
        frame[py::str(name)] = FieldToPython(std::move(field));
      Push(sn, frame);
      Push(kAny, frame);
      ++frames_;
      {
        std::lock_guard lock(state_mutex_);
        seen_.insert(sn);
      }
      cv_.notify_all();
      if (!callback_.is_none()) callback_(frame, param_);
    } catch (py::error_already_set& e) {
      e.discard_as_unraisable("tac3d.Sensor recvCallback");
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tac3d.Sensor: %s\n", e.what());
    }
  }

  void Push(const std::string& key, const py::dict& frame) {
    std::deque<py::object>& queue = queues_[key];
    queue.push_back(frame);
    while (static_cast<int>(queue.size()) > max_queue_) queue.pop_front();
  }

  py::object callback_;
  py::object param_;
  int max_queue_;
  bool drop_initializing_;
  int port_ = 0;
  std::unique_ptr<Client> client_;
  std::mutex client_mutex_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<int> waiting_senders_{0};
  std::atomic<long long> frames_{0};
  std::atomic<long long> initializing_dropped_{0};
  std::map<std::string, std::deque<py::object>> queues_;  // guarded by the GIL
  std::mutex state_mutex_;                                // guards seen_, addresses_
  std::condition_variable cv_;
  std::set<std::string> seen_;
  std::map<std::string, Endpoint> addresses_;
};

void RegisterSensor(py::module_& m) {
  py::class_<Sensor>(m, "Sensor", R"doc(
A Tac3D client with the vendor PyTac3D's interface (Sensor, getFrame, waitForFrame, calibrate,
quitSensor), receiving the Tac3D UDP stream of `tac3d run --udp` or a vendor sensor in C++
(tac3d::Client): reassembly, the incomplete-frame timeout and decoding happen off the GIL.

Each frame is a dict: SN (str), index (int), sendTimestamp (float, the sender's clock, s),
recvTimestamp (float, s since this Sensor was created), message (str), and every item the
sender sent by name: 3D_Displacements, 3D_Positions, 3D_Forces (float64 N x 3),
3D_ResultantForce, 3D_ResultantMoment (float64 1 x 3; tac3d sends the moment in N mm),
InitializeProgress (float as the vendor and tac3d send it; int from earlier versions of tac3d);
when the sender adds them (`tac3d run --udp-items`), 3D_Normals (float64 N x 3) and tac3d's
SlipState (int), SlipFraction, Friction, FrictionSigma (float) and SlipMargin (float64 1 x 3:
the margin to gross slip, its 1-sigma, the least normal force in N). An item not sent is absent.

Frames still initializing (InitializeProgress != 100) are dropped, as the vendor client does,
unless drop_initializing=False. recvCallback(frame, param) runs on the receive thread with the
GIL held, for every frame; getFrame() pops from a queue of at most maxQSize frames per SN (and
one for 'any'), dropping the oldest.
)doc")
      .def(py::init<py::object, int, int, py::object, std::string, double, bool>(),
           py::arg("recvCallback") = py::none(),
           py::arg("port") = 9988,
           py::arg("maxQSize") = 5,
           py::arg("callbackParam") = py::none(),
           py::kw_only(),
           py::arg("bind_address") = "0.0.0.0",
           py::arg("frame_timeout") = 1.0,
           py::arg("drop_initializing") = true,
           "Binds `port` (0: an ephemeral port, see .port) and starts receiving.\n"
           "frame_timeout: seconds after which an incomplete frame is dropped.\n"
           "Raises tac3d.Error if the port cannot be bound or an argument is out of range.")
      .def("getFrame",
           &Sensor::GetFrame,
           py::arg("SN") = kAny,
           "The oldest queued frame of sensor SN ('any': of any sensor), or None.")
      .def("waitForFrame",
           &Sensor::WaitForFrame,
           py::arg("SN") = kAny,
           py::arg("timeout") = py::none(),
           "Blocks (GIL released) until a frame of SN ('any': any) has been received; returns\n"
           "at once if one was. True, or False when `timeout` seconds passed first.\n"
           "Raises tac3d.Error if timeout is negative or NaN.")
      .def(
          "calibrate",
          [](Sensor& s, const std::string& sn) {
            const bool sent = s.Send(sn, SensorCommand::kZero);
            py::print(sent ? fmt::format("Calibrate signal send to {}.", sn)
                           : fmt::format("Calibration failed! (sensor {} is not connected)", sn));
            return sent;
          },
          py::arg("SN"),
          "Sends `$C` (zero: take the present state as undeformed) to the address SN's frames\n"
          "come from. False (and a message) if no frame of SN was received yet.")
      .def(
          "quitSensor",
          [](Sensor& s, const std::string& sn) {
            const bool sent = s.Send(sn, SensorCommand::kStop);
            py::print(sent ? fmt::format("Quit signal send to {}.", sn)
                           : fmt::format("Quit failed! (sensor {} is not connected)", sn));
            return sent;
          },
          py::arg("SN"),
          "Sends `$Q` (stop the sensor process) to SN. False if SN is unknown.")
      .def_property_readonly("port", &Sensor::port, "The bound UDP port.")
      .def("stats",
           &Sensor::Stats,
           "{'frames': delivered, 'initializing_dropped': n, 'drops': {reason: count}}: what the\n"
           "C++ client dropped (incomplete frames timed out, malformed datagrams...).")
      .def("close", &Sensor::Close, "Stops receiving and releases the port (also on exit).")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Sensor& s, py::args) { s.Close(); });

  // Threads must be stopped while the interpreter can still hand them the GIL.
  py::module_::import("atexit").attr("register")(py::cpp_function([] {
    const std::set<Sensor*> open = Sensor::Registry();
    for (Sensor* s : open) s->Close();
  }));
}

}  // namespace tac3d::python
