"""pytest setup: the package under test comes from PYTHONPATH (the build tree's python/, or the unpacked .deb);
the sample captures from the source tree (SAUL_SOURCE_DIR, else two levels up)."""
import os
import pathlib

import pytest

SOURCE = pathlib.Path(os.environ.get("SAUL_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture
def source():
    return SOURCE


@pytest.fixture
def captures():
    return SOURCE / "captures"
