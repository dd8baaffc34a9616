"""Writes python/sombra.pyi, the type stub shipped with the module: the functions and classes as
written in python/sombra.pyi.in, RenderOptions and the keyword arguments of render/shadow_transmittance/
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
    template = Path(__file__).with_name("sombra.pyi.in").read_text()
    text = template.replace("@ATTRIBUTES@", attributes).replace("@KEYWORDS@", keywords)
    out.write_text(text)


if __name__ == "__main__":
    main()
