# The module under test is the one the CMake build made (ctest sets PYTHONPATH to build/python).
import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("SOMBRA_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def context():
    import sombra

    return sombra.Context(os.environ.get("SOMBRA_DEVICE", "auto"))  # as the C++ suite: a --device value
