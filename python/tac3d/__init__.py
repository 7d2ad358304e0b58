"""tac3d: the Tac3D vision-based tactile sensor stack from Python (docs/python.md).

- ``tac3d.Sensor``: the vendor PyTac3D client's interface over the C++ Tac3D UDP client
  (change ``import PyTac3D`` to ``import tac3d as PyTac3D``).
- ``tac3d.open_source`` and ``tac3d.Pipeline``: the in-process pipeline, TactileFrames out.
- ``tac3d.run``, ``SensorSpec``, ``load_run_file``: the runtime of ``tac3d run``, several
  sensors on their threads with their outputs (UDP, recording, JSON lines) and one clock.
- ``tac3d.open_recording``, ``RecordingReader``, ``RecordingWriter``: recordings.
- ``tac3d.load_scene``, ``tac3d.simulate``, ``tac3d.Dataset``: the digital twin;
  ``tac3d.TwinSimulation``: the twin stepped a step a call, under a controller's loads.
- ``tac3d.datasets``: randomized twin datasets generated on Dask and stored as zarr
  (``tac3d.datasets.open(DIR)``; imported on first use, so ``import tac3d`` needs neither).
- ``tac3d.track``, ``tac3d.SingleViewTracker``: a single-view marker sensor's (GelSight-type)
  markers tracked through a video, an image folder or a camera, as ``tac3d track``.
- ``tac3d.design_light_path``, ``tac3d.friction_map``: the design solver and friction map
  (``friction_map_defaults()``: its options, those of ``tac3d friction-map``).

Errors from C++ (bad files, arguments, sockets) are raised as ``tac3d.Error``.
``tac3d.__version__`` is the project's version, the one ``tac3d --version`` prints.
"""

from ._core import (  # noqa: F401
    __version__,
    Dataset,
    Error,
    FrameSource,
    Pipeline,
    Recording,
    RecordingReader,
    RecordingWriter,
    Scene,
    Sensor,
    SensorReport,
    SensorSpec,
    SingleViewTracker,
    TactileFrame,
    TrackedFrame,
    TwinSimulation,
    builtin_scenes,
    default_sensor_yaml,
    design_light_path,
    friction_map,
    friction_map_defaults,
    load_run_file,
    load_scene,
    open_recording,
    open_source,
    parse_scene,
    run,
    simulate,
    simulate_arrays,
)
from .tracking import TrackResult, track  # noqa: F401



def __getattr__(name):
    # tac3d.datasets on first use: zarr and dask stay out of a plain `import tac3d`.
    if name == "datasets":
        import importlib

        return importlib.import_module(".datasets", __name__)
    raise AttributeError(f"module 'tac3d' has no attribute '{name}'")


# The vendor module's version constant, for scripts that print it.
PYTAC3D_VERSION = "3.3.0 (tac3d)"

__all__ = [
    "Dataset", "Error", "FrameSource", "Pipeline", "Recording", "RecordingReader",
    "RecordingWriter", "Scene", "Sensor", "SensorReport", "SensorSpec", "SingleViewTracker", "TactileFrame",
    "TrackedFrame", "TrackResult", "TwinSimulation", "builtin_scenes", "default_sensor_yaml", "design_light_path",
    "friction_map", "friction_map_defaults", "load_run_file", "load_scene", "open_recording", "open_source",
    "parse_scene", "run", "simulate", "simulate_arrays", "track", "PYTAC3D_VERSION",
]
