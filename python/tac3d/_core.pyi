"""Type stubs of tac3d._core, the pybind11 extension (docs/python.md)."""
from types import TracebackType
from typing import Any, Callable, Dict, Iterable, Iterator, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
U8 = npt.NDArray[np.uint8]
Bools = npt.NDArray[np.bool_]
ArrayLike = npt.ArrayLike

__version__: str

class Error(RuntimeError):
    """Bad input (a file, an argument, the network), with the C++ message."""

class TactileFrame:
    """The pipeline's output for one camera frame. Per-marker fields are float64 N x 3 views
    into the frame (writable, no copy); assigning copies in after a shape check."""
    sn: str
    index: int
    timestamp: float
    initialize_progress: int
    flags: int
    positions: F64
    displacements: F64
    forces: F64
    normals: F64
    valid: Bools
    contact: Bools
    resultant_force: F64
    resultant_moment: F64
    def __init__(self, rows: int = 20, cols: int = 20) -> None: ...
    @property
    def rows(self) -> int: ...
    @property
    def cols(self) -> int: ...
    @property
    def num_markers(self) -> int: ...
    @property
    def flag_names(self) -> list[str]: ...
    def has(self, flag: str) -> bool: ...
    @property
    def initializing(self) -> bool: ...
    @property
    def slip_state(self) -> str: ...
    @property
    def slip_fraction(self) -> float: ...
    friction: float
    friction_sigma: float
    slip_margin: float
    slip_margin_sigma: float
    least_normal_force_n: float
    def validate(self) -> None: ...
    def copy(self) -> TactileFrame: ...
    def to_dict(self) -> dict[str, Any]: ...

Frame = dict[str, Any]

class Sensor:
    """The vendor PyTac3D client's interface over the C++ Tac3D UDP client."""
    def __init__(
        self,
        recvCallback: Optional[Callable[[Frame, Any], None]] = None,
        port: int = 9988,
        maxQSize: int = 5,
        callbackParam: Any = None,
        *,
        bind_address: str = "0.0.0.0",
        frame_timeout: float = 1.0,
        drop_initializing: bool = True,
    ) -> None: ...
    def getFrame(self, SN: str = "any") -> Optional[Frame]: ...
    def waitForFrame(self, SN: str = "any", timeout: Optional[float] = None) -> bool: ...
    def calibrate(self, SN: str) -> bool: ...
    def quitSensor(self, SN: str) -> bool: ...
    @property
    def port(self) -> int: ...
    def stats(self) -> dict[str, Any]: ...
    def close(self) -> None: ...
    def __enter__(self) -> Sensor: ...
    def __exit__(self, *args: Any) -> None: ...

class RecordingReader(Iterator[TactileFrame]):
    def __init__(self, path: str) -> None: ...
    def read(self) -> Optional[Tuple[TactileFrame, Optional[U8]]]: ...
    def __iter__(self) -> RecordingReader: ...
    def __next__(self) -> TactileFrame: ...
    @property
    def status(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def frames_read(self) -> int: ...
    @property
    def version(self) -> int: ...

class Recording(Sequence[TactileFrame]):
    def __len__(self) -> int: ...
    def __getitem__(self, i: int) -> TactileFrame: ...  # type: ignore[override]
    def __iter__(self) -> Iterator[TactileFrame]: ...
    def image(self, i: int) -> Optional[U8]: ...
    @property
    def positions(self) -> F64: ...
    @property
    def displacements(self) -> F64: ...
    @property
    def forces(self) -> F64: ...
    @property
    def normals(self) -> F64: ...
    @property
    def resultant_forces(self) -> F64: ...
    @property
    def resultant_moments(self) -> F64: ...
    @property
    def timestamps(self) -> F64: ...
    @property
    def indices(self) -> npt.NDArray[np.int64]: ...
    @property
    def valid(self) -> npt.NDArray[np.bool_]: ...
    @property
    def contact(self) -> npt.NDArray[np.bool_]: ...
    @property
    def flags(self) -> npt.NDArray[np.uint32]: ...
    @property
    def slip(self) -> Dict[str, npt.NDArray[Any]]: ...
    @property
    def status(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def version(self) -> int: ...

def open_recording(path: str, images: bool = True) -> Recording: ...

class RecordingWriter:
    def __init__(self, path: str, overwrite: bool = False, sync_every_frame: bool = False) -> None: ...
    def write(self, frame: TactileFrame, image: Optional[U8] = None) -> None: ...
    @property
    def frames_written(self) -> int: ...
    def close(self) -> None: ...
    def __enter__(self) -> RecordingWriter: ...
    def __exit__(self, *args: Any) -> None: ...

CameraFrame = Tuple[U8, float, int]

class FrameSource(Iterator[CameraFrame]):
    def read(self) -> Optional[CameraFrame]: ...
    def __iter__(self) -> FrameSource: ...
    def __next__(self) -> CameraFrame: ...
    def describe(self) -> str: ...

def open_source(uri: str, width: int = 640, height: int = 480, fps: float = 30.0) -> FrameSource: ...

class Pipeline:
    def __init__(
        self,
        config: str = "",
        cache_dir: str = "",
        sn: Optional[str] = None,
        reference_frames: int = 20,
        weight: Optional[float] = None,
        support_resolve: Optional[bool] = None,
        gains: ArrayLike = (1.0, 1.0, 1.0),
        drift: str = "flag",
        drift_time_constant_s: float = 10.0,
    ) -> None: ...
    def process(self, image: U8, timestamp: float = 0.0) -> TactileFrame: ...
    def recompute_forces(
        self,
        displacements: ArrayLike,
        positions: Optional[ArrayLike] = None,
        valid: Optional[ArrayLike] = None,
        timestamps: Optional[ArrayLike] = None,
    ) -> list[TactileFrame]: ...
    def zero(self) -> None: ...
    @property
    def initializing(self) -> bool: ...

class SensorSpec:
    def __init__(
        self,
        sn: str,
        source: str,
        *,
        config: str = "",
        reference_frames: int = 20,
        weight: Optional[float] = None,
        support_resolve: Optional[bool] = None,
        gains: ArrayLike = (1.0, 1.0, 1.0),
        recompute_forces: bool = False,
        drift: str = "flag",
        drift_time_constant_s: float = 10.0,
        speed: Optional[float] = None,
        fps: float = 30.0,
        exposure: float = 0.0,
        pixel_format: str = "",
        udp: str = "",
        udp_items: str = "",
        udp_progress: bool = False,
        allow_zero_under_load: bool = False,
        record: str = "",
        record_images: bool = False,
        overwrite: bool = False,
        ros2: str = "",
        ros2_reliable: bool = False,
        ros2_image: bool = False,
        ros2_frame_id: str = "",
    ) -> None: ...
    sn: str
    source: str
    config: str
    reference_frames: int
    weight: Optional[float]
    support_resolve: Optional[bool]
    recompute_forces: bool
    gains: list[float]
    drift: str
    drift_time_constant_s: float
    speed: Optional[float]
    fps: float
    exposure: float
    pixel_format: str
    udp: str
    udp_items: str
    udp_progress: bool
    allow_zero_under_load: bool
    record: str
    record_images: bool
    overwrite: bool
    ros2: str
    ros2_reliable: bool
    ros2_image: bool
    ros2_frame_id: str

class SensorReport:
    sn: str
    frames: int
    skipped: int
    failure: str
    warning: str
    last_skip: str
    first_frame_s: float
    last_frame_s: float
    max_gap_s: float
    outputs: str
    def brief_report(self) -> str: ...

def load_run_file(path: str) -> list[SensorSpec]: ...
def run(
    sensors: Sequence[SensorSpec],
    *,
    max_frames: int = 0,
    cache_dir: str = "",
    json: bool = False,
    on_frame: Optional[Callable[[TactileFrame], None]] = None,
) -> list[SensorReport]: ...

class Scene:
    @property
    def name(self) -> str: ...
    @property
    def steps(self) -> int: ...
    def info(self) -> dict[str, Any]: ...

def builtin_scenes() -> list[str]: ...
def load_scene(name_or_path: str) -> Scene: ...
def parse_scene(yaml_text: str, base_dir: str = ".") -> Scene: ...
def simulate(
    scene: Union[Scene, str],
    out: str,
    *,
    cache_dir: str = "",
    steps: int = 0,
    images: bool = True,
    progress: Optional[Callable[[int, int], None]] = None,
    twin_options: Mapping[str, float] = ...,
) -> dict[str, Any]: ...

def simulate_arrays(
    scene: Union[Scene, str],
    *,
    cache_dir: str = "",
    steps: int = 0,
    images: bool = True,
    twin_options: Mapping[str, float] = ...,
    scale_youngs_modulus: bool = True,
    window: bool = True,
    measure: bool = False,
) -> dict[str, Any]: ...
def prepare_twin_body(
    scene: Union[Scene, str],
    *,
    cache_dir: str = "",
    twin_options: Mapping[str, float] = ...,
    scale_youngs_modulus: bool = True,
) -> dict[str, Any]: ...
def prepare_sensor_model(scene: Union[Scene, str], *, cache_dir: str = "") -> dict[str, Any]: ...

class TwinSimulation:
    def __init__(
        self,
        scene: Union[Scene, str],
        *,
        cache_dir: str = "",
        images: bool = True,
        twin_options: Mapping[str, float] = ...,
        scale_youngs_modulus: bool = True,
    ) -> None: ...
    @property
    def num_steps(self) -> int: ...
    @property
    def steps_done(self) -> int: ...
    @property
    def summary(self) -> dict[str, Any]: ...
    def step(
        self,
        normal_force_n: Optional[float] = None,
        tangential_force_n: Optional[tuple[float, float]] = None,
    ) -> dict[str, Any]: ...

class Dataset:
    def __init__(self, folder: str) -> None: ...
    @property
    def header(self) -> dict[str, Any]: ...
    @property
    def steps(self) -> list[int]: ...
    def __len__(self) -> int: ...
    def step(self, step: int, surface: bool = False, image: bool = True) -> dict[str, Any]: ...
    def truth(self) -> dict[str, npt.NDArray[Any]]: ...

class DatasetSpec:
    @property
    def name(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def images(self) -> bool: ...
    @property
    def measured(self) -> bool: ...
    @property
    def sensor(self) -> str: ...
    @property
    def twin_options(self) -> dict[str, Union[float, int]]: ...
    def draw(self, episode: int) -> dict[str, Any]: ...

def load_dataset_spec(path: str) -> DatasetSpec: ...
def parse_dataset_spec(yaml_text: str, base_dir: str = ".") -> DatasetSpec: ...
def design_light_path(
    h_mm: float = 40.0,
    l_mm: float = 40.0,
    d_mm: float = 8.0,
    fov_deg: float = 48.0,
    starts_per_axis: int = 8,
) -> dict[str, Any]: ...
def default_sensor_yaml() -> str: ...
def friction_map(
    frames: Iterable[TactileFrame],
    poses: ArrayLike,
    options: Mapping[str, Union[float, int, bool]] = ...,
    *,
    config: str = "",
) -> dict[str, Any]: ...
def friction_map_defaults() -> dict[str, Union[float, int, bool]]: ...

class TrackedFrame:
    """One frame of a single-view track: the markers row-major, index = row * cols + col."""
    @property
    def index(self) -> int: ...
    @property
    def timestamp_s(self) -> float: ...
    @property
    def rows(self) -> int: ...
    @property
    def cols(self) -> int: ...
    @property
    def image(self) -> U8: ...
    @property
    def xy(self) -> F64: ...
    @property
    def state(self) -> npt.NDArray[np.str_]: ...
    @property
    def acquired(self) -> bool: ...

class SingleViewTracker(Iterator[TrackedFrame]):
    def __init__(
        self,
        source: str,
        grid: Optional[Tuple[int, int]] = None,
        reference: int = 0,
        rest_frames: Sequence[Tuple[int, int]] = (),
        width: int = 640,
        height: int = 480,
        fps: float = 30.0,
    ) -> None: ...
    def __iter__(self) -> SingleViewTracker: ...
    def __next__(self) -> TrackedFrame: ...
    @property
    def rows(self) -> int: ...
    @property
    def cols(self) -> int: ...
    @property
    def reference_xy(self) -> F64: ...
    @property
    def summary(self) -> dict[str, Union[str, float, int]]: ...
