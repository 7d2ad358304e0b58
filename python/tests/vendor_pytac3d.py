"""A receiver that behaves as the vendor's Python client PyTac3D 3.3.0-p1 (shipped with SDK
3.2.1) does, written from the facts in docs/pipeline.md ("The UDP stream and the vendor's
clients"), not from the vendor's code, with plain sockets: it shares nothing with tac3d's own
client.

It decodes every item it can (mat f64, f64, i32; img kept as bytes) into a dict by name, so
extra items are harmless; but its decode loop ends for good at the first frame whose
InitializeProgress is not 100, so a client started before a sender that streams its
initialisation receives nothing at all.
"""
import socket
import struct
import threading

import numpy as np
import yaml


class PyTac3DClient:
    CHUNK = 1392

    def __init__(self, port=0):
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self._sock.bind(("127.0.0.1", port))
        self._sock.settimeout(0.05)
        self.port = self._sock.getsockname()[1]
        self.frames = []       # the decoded frames the callback got, in order
        self.gave_up_at = None  # the index of the frame that ended the decode loop
        self.on_frame = None    # callback(frame), on the receive thread
        self._sender = None
        self._partials = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def calibrate(self):
        """Sends `$C` to the address the frames came from."""
        self._sock.sendto(b"$C", self._sender)

    def close(self):
        self._stop.set()
        self._thread.join()
        self._sock.close()

    def _loop(self):
        while not self._stop.is_set():
            try:
                datagram, sender = self._sock.recvfrom(1 << 16)
            except socket.timeout:
                continue
            frame = self._reassemble(datagram)
            if frame is None:
                continue
            self._sender = sender
            decoded = self._decode(*frame)
            if decoded["InitializeProgress"] != 100:
                self.gave_up_at = decoded["index"]
                return  # 3.3.0-p1's decode thread returns here instead of skipping the frame
            self.frames.append(decoded)
            if self.on_frame:
                self.on_frame(decoded)

    def _reassemble(self, datagram):
        frame_id, count, index = struct.unpack_from("<IHH", datagram)
        partial = self._partials.setdefault(frame_id, {})
        partial[index] = datagram[8:]
        if len(partial) < count + 1:
            return None
        del self._partials[frame_id]
        return partial[0], b"".join(partial[k] for k in range(1, count + 1))

    @staticmethod
    def _decode(header, body):
        head = yaml.safe_load(header.decode("ascii"))
        frame = {"SN": head["SN"], "index": head["index"], "sendTimestamp": head["timestamp"]}
        for item in head["data"]:
            raw = body[item["offset"]:item["offset"] + item["length"]]
            if item["type"] == "mat":
                value = np.frombuffer(raw, "<f8").reshape(item["height"], item["width"])
            elif item["type"] == "f64":
                value = struct.unpack("<d", raw)[0]
            elif item["type"] == "i32":
                value = struct.unpack("<i", raw)[0]
            else:
                value = raw
            frame[item["name"]] = value
        return frame
