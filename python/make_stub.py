"""Writes python/sombra.pyi, the type stub shipped with the module: the functions and classes by
hand below, RenderOptions and the keyword arguments of render/shadow_transmittance/
build_deep_shadow_maps from render_option_declarations() (each option declared once in C++,
include/sombra/options.h). ctest "python: the .pyi stub is what make_stub.py writes" keeps the
committed file in sync; usage: PYTHONPATH=build/python python3 python/make_stub.py [OUT]."""
import sys
from pathlib import Path

import sombra

PY_TYPES = {"int": "int", "float": "float", "str": "str", "bool": "bool"}


def option_type(declaration):
    if declaration["type"] == "str" and declaration["choices"]:
        return "Literal[" + ", ".join(repr(c) for c in declaration["choices"]) + "]"
    return PY_TYPES[declaration["type"]]


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("sombra.pyi")
    declarations = sombra.render_option_declarations()
    attributes = "\n".join(f"    {d['key']}: {option_type(d)}  # {d['help'].splitlines()[0]}" for d in declarations)
    keywords = "\n".join(f"    {d['key']}: {option_type(d)}" for d in declarations)
    text = TEMPLATE.replace("@ATTRIBUTES@", attributes).replace("@KEYWORDS@", keywords)
    out.write_text(text)


TEMPLATE = '''# Type stub of the module `sombra` (python/sombra_module.cpp), written by python/make_stub.py:
# RenderOptions and the option keywords come from the options' declarations (docs/options.md).
from typing import Any, Literal, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt
from typing_extensions import Unpack

__version__: str

Vec3 = Union[Sequence[float], npt.NDArray[Any]]
Stats = dict[str, Any]

class Error(Exception): ...

class Context:
    device: str
    def __init__(self, device: str = "auto") -> None: ...
    def release_prepared_scenes(self) -> None: ...

class RenderOptions:
@ATTRIBUTES@
    def __init__(self, **kwargs: Unpack[RenderOptionKeywords]) -> None: ...
    def copy(self) -> RenderOptions: ...

class RenderOptionKeywords(TypedDict, total=False):
@KEYWORDS@

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

def list_devices() -> list[dict[str, Any]]: ...
def load_scene(path: str, non_finite: Literal["reject", "sanitize"] = "reject") -> Scene: ...
def volume_info(path: str, grid: str = "") -> dict[str, Any]: ...
def render_option_declarations() -> list[dict[str, Any]]: ...
def render(
    context: Context, scene: Scene, options: Optional[RenderOptions] = None, **kwargs: Unpack[RenderOptionKeywords]
) -> tuple[npt.NDArray[np.float32], Stats]: ...
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
def write_image(path: str, image: npt.ArrayLike, background: Vec3 = (0, 0, 0)) -> None: ...
'''

if __name__ == "__main__":
    main()
