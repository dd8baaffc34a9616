# The module under test is the one the CMake build made (ctest sets PYTHONPATH to build/python).
import os
import pathlib

import pytest

# as the C++ suite (tests/main.cpp): no shadow-cache history across runs, so that what one run
# measured cannot change what the next one tests
os.environ.setdefault("SOMBRA_AUTO_HISTORY", "off")

SOURCE_DIR = pathlib.Path(os.environ.get("SOMBRA_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def context():
    import sombra

    return sombra.Context(os.environ.get("SOMBRA_DEVICE", "auto"))  # as the C++ suite: a --device value
