# Type stub of the module `sombra` (python/sombra_module.cpp), written by python/make_stub.py from sombra.pyi.in:
# RenderOptions and the option keywords come from the options' declarations (docs/options.md).
from typing import Any, Literal, NamedTuple, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt
from typing_extensions import Unpack

__version__: str

Vec3 = Union[Sequence[float], npt.NDArray[Any]]
Stats = dict[str, Any]

class Error(Exception): ...

class Rendered(NamedTuple):
    image: npt.NDArray[np.float32]
    stats: Stats
    def _repr_png_(self) -> bytes: ...

class Context:
    device: str
    def __init__(self, device: str = "auto") -> None: ...
    def release_prepared_scenes(self) -> None: ...

class RenderOptions:
    width: int  # image width
    height: int  # image height
    shadows: Literal['none', 'rays', 'dsm', 'shadowmap', 'lowpass', 'ao', 'cone']  # the shadow technique:
    shading: Literal['phong', 'scattering']  # phong (gradient normals) or scattering (single scattering with shadows, Ament 2014 Eq. 1-3)
    phase_g: float  # Henyey-Greenstein asymmetry g for --shading scattering
    gradient: Literal['central', 'sobel']  # central or sobel
    shadow_cache: Literal['auto', 'on', 'off']  # the shadow term per volume and light on a lattice, filled by the technique, read trilinearly: on, off, or auto (on when a short probe of both finds the fill and the cached camera pass cheaper than evaluating the technique per sample; later runs of a frame choose by the times earlier runs recorded)
    shadow_cache_fill: Literal['visible', 'all']  # which lattice points a shadow cache fill evaluates: visible (those this frame's samples read, found by a marking camera pass; a frame from another view completes the lattice) or all (every point near a visible brick at once, no marking pass); the image is the same
    volume_storage: Literal['auto', 'buffer', 'image']  # auto (buffer on CPUs, image on GPUs), buffer or image
    empty_space_skipping: bool  # march empty bricks too (for comparisons)
    termination_transmittance: float  # early ray termination: a camera ray stops when its transmittance falls below this
    jitter_seed: int  # seed of the per-pixel ray jitter
    lanes: int  # rays per work-item in vector types (camera pass, DSM generation, low-pass table resampling): 1, 4, 8, 16, or 0: on CPUs 8 in the camera pass and the native float vector width in the light passes, 1 on GPUs
    dsm_resolution: int  # deep shadow map texels per side
    dsm_epsilon: float  # deep shadow map compression error bound ε (Knecht Eq. 3.1)
    dsm_error: Literal['absolute', 'relative']  # what ε bounds: absolute (opacity, |α' − α| ≤ ε) or relative (optical depth, |τ' − τ| ≤ ε: the light that is left within a factor e^±ε, dim regions kept)
    dsm_step: float  # DSM generation: factor on each volume's step for the rays from the light (> 1: faster, coarser)
    dsm_storage: Literal['atlas', 'chunked', 'chunked-ondemand', 'compact']  # deep shadow map storage: atlas, chunked, chunked-ondemand (Knecht) or compact
    dsm_lookup: Literal['packed', 'native']  # DSM lookups: packed (each texel's nodes copied into one run after generation) or native (in the storage's own layout)
    dsm_precompression: bool  # pre-compressed visibility tables for DSM generation (Hadwiger §3.2)
    dsm_prefilter: Literal['none', 'box', 'tent', '5tap']  # DSM pre-filtering: none, box (2×2 sub-pixel rays), tent (4×4) or 5tap (centre + 4 corners)
    dsm_prefilter_jitter: bool  # pre-filtering: sub-pixel rays at the centres of their cells, not jittered
    dsm_prefilter_seed: int  # pre-filtering: seed of the sub-pixel rays' jitter
    dsm_clusters: int  # clustered deep shadow maps (Knecht §3.4): at most M object clusters per light, each with its own --dsm-res map focused on it
    dsm_cluster_distance: float  # clustering threshold d0 in light space
    dsm_cluster_hysteresis: float  # keep the previous frame's clusters while their spread is within 1 + H of new ones (API re-renders)
    lowpass_filter_width: float  # lowpass: filter width W (the softness of the shadows); ao: the cube's side
    lowpass_filter_kernel: Literal['box', 'gauss']  # lowpass: box (one SAT box) or gauss (5×5 sub-boxes, Ament Eq. 25)
    lowpass_max_entries: int  # summed-area tables: at most this many 64-bit entries in the tables of one frame or point light (cells coarsen beyond)
    lowpass_cells_across: float  # lowpass: the filter's patch spans at least N table cells across the light, a wider W coarsening the cells across the light by W/N; ao: the cube spans at least N cells, a wider W coarsening every cell by W/N (0: cells of the finest voxel whatever W, so that changing W rebuilds no table)
    lowpass_precision: Literal['auto', 'double', 'float']  # summed-area-table lookups in auto (double where the device has it), double or float arithmetic
    cone_angle_deg: float  # cone: half angle of the shadow cones
    shadow_ray_step: float  # rays: factor on each volume's step for the shadow rays (< 1: finer)
    ray_cache_lattice: Literal['light', 'volume']  # rays: the shadow cache's lattice per volume and light: light (columns along the light's rays, one march fills a column; where the volume lies to one side of a positional light) or volume (the voxel axes, one ray per point)
    def __init__(self, **kwargs: Unpack[RenderOptionKeywords]) -> None: ...
    def copy(self) -> RenderOptions: ...

class RenderOptionKeywords(TypedDict, total=False):
    width: int
    height: int
    shadows: Literal['none', 'rays', 'dsm', 'shadowmap', 'lowpass', 'ao', 'cone']
    shading: Literal['phong', 'scattering']
    phase_g: float
    gradient: Literal['central', 'sobel']
    shadow_cache: Literal['auto', 'on', 'off']
    shadow_cache_fill: Literal['visible', 'all']
    volume_storage: Literal['auto', 'buffer', 'image']
    empty_space_skipping: bool
    termination_transmittance: float
    jitter_seed: int
    lanes: int
    dsm_resolution: int
    dsm_epsilon: float
    dsm_error: Literal['absolute', 'relative']
    dsm_step: float
    dsm_storage: Literal['atlas', 'chunked', 'chunked-ondemand', 'compact']
    dsm_lookup: Literal['packed', 'native']
    dsm_precompression: bool
    dsm_prefilter: Literal['none', 'box', 'tent', '5tap']
    dsm_prefilter_jitter: bool
    dsm_prefilter_seed: int
    dsm_clusters: int
    dsm_cluster_distance: float
    dsm_cluster_hysteresis: float
    lowpass_filter_width: float
    lowpass_filter_kernel: Literal['box', 'gauss']
    lowpass_max_entries: int
    lowpass_cells_across: float
    lowpass_precision: Literal['auto', 'double', 'float']
    cone_angle_deg: float
    shadow_ray_step: float
    ray_cache_lattice: Literal['light', 'volume']

class Scene:
    width: int
    height: int
    ambient_intensity: float
    background: tuple[float, float, float]
    @property
    def volume_count(self) -> int: ...
    @property
    def light_count(self) -> int: ...
    @property
    def source(self) -> str: ...
    def __init__(self, width: int = 512, height: int = 512) -> None: ...
    def add_volume(
        self,
        voxels: npt.ArrayLike,
        spacing: Vec3 = (1, 1, 1),
        transform: Optional[npt.ArrayLike] = None,
        opacity: Sequence[Sequence[float]] = ...,
        color: Sequence[Sequence[float]] = ...,
        step_voxels: float = 0.5,
        opacity_unit: float = 0.0,
        name: str = "",
    ) -> int: ...
    def add_mesh(
        self,
        vertices: npt.ArrayLike,
        triangles: npt.ArrayLike,
        color: Vec3 = (0.8, 0.8, 0.8),
        opacity: float = 1.0,
        transform: Optional[npt.ArrayLike] = None,
        name: str = "",
    ) -> int: ...
    def add_light(
        self,
        type: Literal["directional", "spot", "point"],
        position: Vec3 = (0, 0, 0),
        direction: Vec3 = (0, 0, -1),
        color: Vec3 = (1, 1, 1),
        intensity: float = 1.0,
        cone_angle_deg: float = 30.0,
    ) -> int: ...
    def set_camera(self, position: Vec3, look_at: Vec3, up: Vec3 = (0, 1, 0), fov_y_deg: float = 40.0) -> None: ...
    def render_options(self) -> RenderOptions: ...
    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
    def volume_bounds(self, index: int) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
    def value_range(self, index: int) -> tuple[float, float]: ...

class DeepShadowMap:
    width: int
    height: int
    light_name: str
    @property
    def first(self) -> npt.NDArray[np.uint32]: ...
    @property
    def depth(self) -> npt.NDArray[np.float32]: ...
    @property
    def opacity(self) -> npt.NDArray[np.float32]: ...
    @property
    def world_to_camera(self) -> npt.NDArray[np.float32]: ...
    @property
    def world_to_ndc(self) -> npt.NDArray[np.float32]: ...
    def write_exr(self, path: str) -> None: ...

def forget_shadow_cache_choices() -> None: ...
def list_devices() -> list[dict[str, Any]]: ...
def load_scene(path: str, non_finite: Literal["reject", "sanitize"] = "reject") -> Scene: ...
def volume_info(path: str, grid: str = "") -> dict[str, Any]: ...
def render_option_declarations() -> list[dict[str, Any]]: ...
def render(
    context: Context, scene: Scene, options: Optional[RenderOptions] = None, **kwargs: Unpack[RenderOptionKeywords]
) -> Rendered: ...
def shadow_transmittance(
    context: Context,
    scene: Scene,
    light: int,
    points: npt.ArrayLike,
    options: Optional[RenderOptions] = None,
    **kwargs: Unpack[RenderOptionKeywords],
) -> tuple[npt.NDArray[np.float64], Stats]: ...
def reference_transmittance(scene: Scene, light: int, points: npt.ArrayLike, step_voxels: float = 0.05) -> npt.NDArray[np.float64]: ...
def build_deep_shadow_maps(
    context: Context, scene: Scene, light: int, options: Optional[RenderOptions] = None, **kwargs: Unpack[RenderOptionKeywords]
) -> tuple[list[DeepShadowMap], Stats]: ...
def read_deep_exr(path: str) -> DeepShadowMap: ...
def load_mesh(path: str) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.uint32]]: ...
def write_image(path: str, image: npt.ArrayLike, background: Vec3 = (0, 0, 0)) -> None: ...
