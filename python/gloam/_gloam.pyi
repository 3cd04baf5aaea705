"""Type stubs of gloam's extension module (see gloam/__init__.py)."""

from os import PathLike
from types import TracebackType
from typing import Any, Callable, Dict, Iterator, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._results import (
    AgcLinearity,
    Comparison,
    Effect,
    Ephemeris,
    FrameMeta,
    FrameRecord,
    Mtf,
    PhotonTransfer,
    Probe,
    RadianceCalibration,
    RenderReport,
    Result,
    Scope,
    SensorDescription,
    SkyIlluminance,
    SweepResult,
)

_Path = Union[str, PathLike]
_Settings = Dict[str, Union[str, int, float, bool]]
# progress=True (a tqdm bar when tqdm is installed) or progress(done, total, what).
_Progress = Union[bool, None, Callable[[int, int, str], Any]]
# Any real dtype and memory layout; converted to float64 exactly.
_Image = npt.ArrayLike

__version__: str

class GloamError(ValueError):
    """Bad input (the message names file, line and field), a device or a calibration that failed."""

class Scene:
    """A scene: TOML with inline geometry or OBJ files (docs/scene-format.md)."""

    @staticmethod
    def load(path: _Path) -> "Scene": ...
    @staticmethod
    def from_toml(text: str, base_dir: Optional[_Path] = None, name: str = "scene.toml") -> "Scene": ...
    def plan(self, settings: Optional[_Settings] = None, tolerance: Optional[float] = None) -> List[Effect]:
        """The effect plan: one Effect per effect (name, enabled, reason, estimated_share)."""
    @property
    def bands(self) -> List[Dict[str, Any]]: ...
    @property
    def path(self) -> str: ...

class RenderResult:
    """A render: radiance (float64 band × row × column, W m⁻² sr⁻¹) and its report."""

    @property
    def radiance(self) -> npt.NDArray[np.float64]: ...
    @property
    def std_error(self) -> npt.NDArray[np.float64]: ...
    @property
    def spp(self) -> npt.NDArray[np.uint32]: ...
    @property
    def detected(self) -> Optional[npt.NDArray[np.float64]]:
        """Detected-electron radiance (e⁻ s⁻¹ m⁻² sr⁻¹, row × column) when rendered with sensor=."""
    @property
    def bands(self) -> List[Dict[str, Any]]: ...
    @property
    def report(self) -> RenderReport:
        """The document report.json holds."""
    def to_dict(self) -> Dict[str, Any]: ...
    def __getitem__(self, key: str) -> Any: ...

def render(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    estimator: Optional[Literal["analytic", "solid-angle", "dirsig2001"]] = None,
    settings: Optional[_Settings] = None,
    threads: Optional[int] = None,
    target_error: Union[float, str, None] = None,
    tolerance: Optional[float] = None,
    sensor: Union["Sensor", str, None] = None,
    progress: _Progress = None,
) -> RenderResult:
    """Renders a scene as `gloam render` does (bit-identical radiance for the same seed)."""

def probe(
    scene: Scene,
    point: Sequence[float],
    normal: Sequence[float],
    band: Optional[str] = None,
    samples: int = 16,
    seed: Optional[int] = None,
    estimator: Optional[str] = None,
    settings: Optional[_Settings] = None,
) -> Probe:
    """Irradiance at a point (irradiance_w_m2, std_error_w_m2, radiance_w_m2_sr)."""

class Sensor:
    """A camera model: a built-in preset or a sensor TOML file."""

    @staticmethod
    def preset(name: str) -> "Sensor": ...
    @staticmethod
    def from_toml(path: _Path) -> "Sensor": ...
    @staticmethod
    def presets() -> List[str]: ...
    @property
    def name(self) -> str: ...
    def describe(self, gain: Optional[float] = None) -> SensorDescription: ...
    def capture(
        self,
        image: Union[RenderResult, _Image],
        frames: int = 1,
        gain: Optional[float] = None,
        agc: bool = False,
        seed: int = 0,
        noise: bool = True,
        input: Literal["detected", "photoelectrons"] = "detected",
        progress: _Progress = None,
    ) -> "Capture": ...

class Capture:
    """Frames (uint16, frames × row × column) and one metadata dict per frame."""

    @property
    def frames(self) -> npt.NDArray[np.uint16]: ...
    @property
    def meta(self) -> List[FrameRecord]: ...
    @property
    def sensor(self) -> str: ...
    def __len__(self) -> int: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __getitem__(self, key: str) -> Any: ...

class Frame:
    @property
    def pixels(self) -> npt.NDArray[np.uint16]: ...
    @property
    def gain(self) -> float: ...
    @property
    def meta(self) -> FrameMeta: ...

class FrameStream(Iterator[Frame]):
    def __iter__(self) -> "FrameStream": ...
    def __next__(self) -> Frame: ...

class Grabber:
    """An open frame grabber; a context manager."""

    def __enter__(self) -> "Grabber": ...
    def __exit__(
        self,
        exc_type: Optional[type] = None,
        exc: Optional[BaseException] = None,
        tb: Optional[TracebackType] = None,
    ) -> bool: ...
    def close(self) -> None: ...
    def describe(self) -> str: ...
    @property
    def frame_size(self) -> Tuple[int, int]: ...
    def set_gain(self, gain: float) -> float: ...
    def set_agc(self, on: bool) -> bool: ...
    def set_exposure(self, exposure_s: float) -> float: ...
    def set_bits(self, bits: int) -> int: ...
    def present(self, stimulus: Dict[str, Any]) -> bool: ...
    def grab(self) -> Frame: ...
    def stream(self, n: int) -> FrameStream: ...

def open_grabber(uri: str, seed: Optional[int] = None) -> Grabber:
    """Opens sim:…, serial:…, usb:…, genicam:… as the CLI's --grabber does."""

class Lut:
    @staticmethod
    def load(path: _Path) -> "Lut": ...
    @staticmethod
    def from_dict(d: Dict[str, Any]) -> "Lut": ...
    def to_dict(self) -> RadianceCalibration: ...
    @property
    def gains(self) -> List[float]: ...
    def apply(self, frame: Union[Frame, npt.NDArray[np.uint16]], gain: Optional[float] = None) -> npt.NDArray[np.float32]: ...

def calibrate_radiance(
    grabber: Grabber,
    source: _Path,
    gains: Sequence[float],
    frames: int = 8,
    levels: Optional[int] = None,
    auto_range: Optional[float] = None,
    exposure_s: Optional[float] = None,
) -> RadianceCalibration: ...
def photon_transfer(
    grabber: Grabber,
    source: _Path,
    gain: float = 1.0,
    levels: int = 50,
    spatial_frames: int = 16,
    auto_range: Optional[float] = None,
    exposure_s: Optional[float] = None,
    dataset_dir: Optional[_Path] = None,
) -> PhotonTransfer: ...
def mtf(
    grabber: Grabber,
    target: Literal["edge", "sine"] = "edge",
    gain: Optional[float] = None,
    radiance: Optional[float] = None,
    modulation: float = 0.8,
    angle_deg: Optional[float] = None,
    frequencies: Optional[Sequence[float]] = None,
    frames: int = 8,
    spectrum: str = "cie-a",
    space: Literal["digital", "voltage"] = "digital",
    scope_rows: Optional[Sequence[int]] = None,
    magnification: float = 1.0,
) -> Mtf: ...
def agc_linearity(
    grabber: Grabber,
    source: _Path,
    fixed_gain: Optional[float] = None,
    frames: int = 60,
    levels: Optional[int] = None,
    auto_range: Optional[float] = None,
    lut: Optional[Lut] = None,
    allow_unsettled: bool = False,
) -> AgcLinearity: ...
def compare(
    truth: _Image,
    synthetic: _Image,
    regions: List[Dict[str, Any]],
) -> Comparison: ...
def scope(
    sensor: Optional[str] = None,
    grabber: Optional[str] = None,
    rig: Optional[Literal["uniform", "sine", "edge", "dark"]] = None,
    frequency: float = 0.05,
    level: float = 0.4,
    rows: Optional[Sequence[int]] = None,
    size: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    gain: Optional[float] = None,
    format: Optional[Literal["rs-170", "ccir"]] = None,
    bandwidth_hz: Optional[float] = None,
    frames: int = 1,
) -> Scope:
    """A simulated camera's video lines on the oscilloscope (gloam scope)."""
def sweep(path: _Path, out: _Path, jobs: Optional[int] = None, progress: _Progress = None) -> SweepResult:
    """Plans, runs (resuming) and collects a sweep, as gloam sweep SWEEP.toml --out DIR."""
def ephem(lat: float, lon: float, utc: str, height_m: float = 0.0) -> Ephemeris: ...
def sky(
    lat: float,
    lon: float,
    utc: str,
    height_m: float = 0.0,
    visibility_km: float = 23.0,
    overcast: bool = False,
    spectra: bool = False,
) -> SkyIlluminance: ...
