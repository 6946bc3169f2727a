"""Type stubs of the `flare` module (docs/python.md), copied beside the built module so that editors
and type checkers complete it. tests/python/test_flare_module.py checks that every name and every
parameter here is the module's."""
from typing import Any, Callable, Dict, ItemsView, Iterable, Iterator, KeysView, List, Mapping, Optional, Sequence, Tuple, Union, ValuesView

import numpy as np
import numpy.typing as npt

__version__: str

Image = npt.NDArray[np.float32]
"""float32 array (height, width, 3): linear Rec.709 RGB, sensor irradiance in W/m2, first row at the top."""

class Footprint:
    """A layer over a window of its frame (a ghost's footprint: the bounding box of the pixels it reaches;
    every pixel outside is zero). np.asarray(footprint) is the whole frame."""
    @property
    def name(self) -> str: ...
    @property
    def x(self) -> int: ...
    @property
    def y(self) -> int: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def frame_size(self) -> Tuple[int, int]: ...
    @property
    def rgb(self) -> Image: ...
    def full(self) -> Image: ...

Layer = Union[Image, Footprint]

class FlareWarning(UserWarning):
    """A problem the engine worked around with a stated fallback, issued through `warnings`."""

class Paraxial:
    """First-order data of a lens at one wavelength (lengths in mm)."""
    @property
    def wavelength_nm(self) -> float: ...
    @property
    def efl_mm(self) -> float: ...
    @property
    def bfl_mm(self) -> float: ...
    @property
    def front_focal_distance_mm(self) -> float: ...
    @property
    def image_distance_mm(self) -> float: ...
    @property
    def entrance_pupil_z_mm(self) -> float: ...
    @property
    def entrance_pupil_diameter_mm(self) -> float: ...
    @property
    def exit_pupil_z_mm(self) -> float: ...
    @property
    def exit_pupil_diameter_mm(self) -> float: ...
    @property
    def f_number(self) -> float: ...
    @property
    def working_f_number(self) -> float: ...
    @property
    def field_of_view_deg(self) -> float: ...
    @property
    def total_track_mm(self) -> float: ...

class Lens:
    """A lens at one zoom/focus/f-stop state."""
    @property
    def name(self) -> str: ...
    @property
    def source_file(self) -> str: ...
    @property
    def surface_count(self) -> int: ...
    def paraxial(self, wavelength_nm: float = 587.5618) -> Paraxial:
        """Paraxial data at a wavelength in [300, 2000] nm."""
    def info(self, wavelength_nm: float = 587.5618) -> Dict[str, Any]:
        """The dict `flare lens info --json` prints."""
    def ghost_report(self, *, field_deg: Optional[Sequence[float]] = None, order: int = 2, wavelength_nm: float = 550.0,
                     all: bool = False, sensor_ghosts: bool = True) -> Dict[str, Any]:
        """The dict `flare ghosts LENS --json` prints."""
    def ghosts(self, *, field_deg: Optional[Sequence[float]] = None, order: int = 2, wavelength_nm: float = 550.0,
               all: bool = False, sensor_ghosts: bool = True) -> List[Dict[str, Any]]:
        """The ghost table, strongest first."""

class Scene:
    """A scene (docs/scene-format.md); the lens, its state, resolution and render settings are settable."""
    @property
    def source_file(self) -> str: ...
    description: str
    lens_name: str
    zoom: Union[str, float, None]
    focus_distance_mm: Optional[float]
    f_number: Optional[float]
    resolution: Tuple[int, int]
    @property
    def width_px(self) -> int: ...
    @property
    def height_px(self) -> int: ...
    sensor_size_mm: Optional[Tuple[float, float]]
    @property
    def light_names(self) -> List[str]: ...
    photons: int
    seed: int
    diffraction: bool
    ghost_ringing: bool
    beams_per_pass: int
    ghost_order: int
    def copy(self) -> Scene:
        """An independent copy."""
    def __copy__(self) -> Scene: ...
    def __deepcopy__(self, memo: Any) -> Scene: ...
    def lens(self) -> Lens:
        """The scene's lens at the scene's state and sensor."""
    def ghost_report(self, *, light: int = 0, field_deg: Optional[Sequence[float]] = None, order: int = 2,
                     wavelength_nm: float = 550.0, all: bool = False, sensor_ghosts: bool = True) -> Dict[str, Any]:
        """The dict `flare ghosts SCENE.json --json` prints, for one light (0-based)."""
    def ghosts(self, *, light: int = 0, field_deg: Optional[Sequence[float]] = None, order: int = 2,
               wavelength_nm: float = 550.0, all: bool = False, sensor_ghosts: bool = True) -> List[Dict[str, Any]]:
        """The ghost table, strongest first."""

class RenderResult(Mapping[str, Image]):
    """flare.render's result: a mapping from EXR layer name to image, with the render's report."""
    @property
    def images(self) -> Dict[str, Image]: ...
    @property
    def report(self) -> Dict[str, Any]:
        """The dict `flare render --report` writes."""
    def __getitem__(self, name: str) -> Image: ...
    def __contains__(self, name: object) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> KeysView[str]: ...
    def values(self) -> ValuesView[Image]: ...
    def items(self) -> ItemsView[str, Image]: ...
    def get(self, name: str, default: Any = None) -> Any: ...

def load_lens(lens: str, *, zoom: Union[str, float, None] = "", focus_mm: Optional[float] = None,
              f_number: Optional[float] = None, glass_catalog: Union[str, Sequence[str], None] = None) -> Lens:
    """A lens file (.lens, .dat, .zmx), a shipped lens name or a library id at a state."""
def lens_names() -> List[str]:
    """The shipped lens names, then the library's ids."""
def lens_list(*, maker: str = "", focal_mm: Union[float, Tuple[Optional[float], Optional[float]], None] = None,
              f_number: Optional[float] = None) -> List[Dict[str, Any]]:
    """The library's lenses as `flare lens list --json` lists them."""
def lens_search(text: str) -> List[Dict[str, Any]]:
    """Library lenses matching every word, as `flare lens search --json`."""
def load_scene(path: str) -> Scene:
    """A scene file (JSON)."""
def default_scene() -> Scene:
    """The embedded default scene."""
def default_scene_text() -> str:
    """The default scene's JSON text."""
def parse_scene(scene: Union[str, Mapping[str, Any]], *, file_name: str = "<string>", base_dir: str = "") -> Scene:
    """A scene from JSON text or a dict."""
def preview(scene: Scene, *, layers: Union[bool, str] = False, threads: int = 0, diffraction: Optional[bool] = None,
            passes: int = 2, time: float = 0.0, seed: Optional[int] = None, higher: bool = False) -> Dict[str, Layer]:
    """The ghost preview, as `flare preview`."""
def render(scene: Scene, *, photons: Optional[int] = None, time_s: Optional[float] = None, target_error: float = 0.02,
           seed: Optional[int] = None, threads: int = 0, mode: str = "guided", layers: Union[bool, str] = False,
           max_bounces: Optional[int] = None, higher_order: str = "auto", kernel: str = "fixed",
           radius_px: float = 1.0, smooth_neighbours: int = 256, interior_albedo: Optional[float] = None,
           diffraction: Optional[bool] = None, analog_stray: bool = False, beam_replicates: int = 2, beam_probes: int = 4,
           scatter_splits: int = 8, progress: Optional[Callable[[Dict[str, Any]], Optional[bool]]] = None, checkpoint: Optional[str] = None,
           checkpoint_interval_s: float = 60.0) -> RenderResult:
    """The physically based render, as `flare render`."""
def write_exr(path: str, images: Mapping[str, npt.ArrayLike], *, metadata: Mapping[str, str] = ...,
              half_layers: Sequence[str] = ..., compression: str = "zip") -> None:
    """Writes images as an EXR, as the CLI writes its EXRs."""
def compare(a: Union[str, npt.ArrayLike], b: Union[str, npt.ArrayLike], *, layer: str = "") -> Dict[str, Any]:
    """Error metrics of a against the reference b, as `flare compare --json`."""
def read_exr(path: str) -> Dict[str, Layer]:
    """Every RGB layer of an EXR."""
