"""Fixtures shared by the whole test suite (core and QGIS tests).

- ``shared_data``: the real LiDAR tiles and city models in ``../shared/data`` beside the
  repository root (never copied into the repository); tests using it skip when it is absent.
  ``URBANVOX_SHARED_DATA`` overrides the location.
- ``district``: the synthetic district of :mod:`core.synthetic` (seed 0), written once per
  session to a temporary folder as LAZ, building STL and ground STL, with its truth.
- ``compiled``: the compiled kernel modules of :mod:`core.jit` by name; the test fails
  if numba is missing, or if a kernel call fell back to numpy while it ran.
"""

import os
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
if str(REPO_ROOT) not in sys.path:  # `import core` whichever way pytest was started
    sys.path.insert(0, str(REPO_ROOT))


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: runs the whole pipeline on real data (seconds to a minute each)")
    config.addinivalue_line("markers", "qgis: needs QGIS (tests/qgis)")


@pytest.fixture
def compiled():
    """``compiled(name)`` is the kernel module ``core.<name>`` (core.jit)."""
    from core import jit

    failed = len(jit.failures)

    def kernel(name):
        module = jit.kernels(name)
        # numba is in requirements.txt: the suite must run the kernels, not skip them.
        assert module is not None, "numba did not import: pip install -c constraints.txt -r requirements.txt"
        return module

    yield kernel
    # A failing call falls back to numpy (jit.run): comparisons with numpy would pass without the kernel.
    assert jit.failures[failed:] == []


@pytest.fixture
def with_numpy(monkeypatch):
    """``with_numpy(function, *args)`` is ``function(*args)`` with the compiled
    kernels off: the numpy twins a kernel is compared with."""
    def run(function, *args):
        with monkeypatch.context() as patch:
            patch.setenv("URBANVOX_JIT", "0")
            return function(*args)

    return run


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of the real test data folder; skips the test when it is not there."""
    path = Path(os.environ.get("URBANVOX_SHARED_DATA", REPO_ROOT.parent / "shared" / "data"))
    if not path.is_dir():
        pytest.skip(f"real test data not found at {path} (set URBANVOX_SHARED_DATA)")
    return path


@dataclass(frozen=True)
class DistrictFiles:
    """The synthetic district and its files (all in EPSG:2056; the STLs carry no CRS)."""

    district: "object"  # core.synthetic.District
    folder: Path
    laz: Path
    stl: Path
    ground_stl: Path
    crs: str = "EPSG:2056"

    @property
    def blocks(self):
        """Truth blocks (:class:`core.synthetic.BlockTruth`)."""
        return self.district.blocks

    @property
    def expected_blocks(self):
        """Truth blocks that pass the default thresholds."""
        return [b for b in self.district.blocks if not b.below_thresholds]


@pytest.fixture(scope="session")
def district(tmp_path_factory) -> DistrictFiles:
    """The synthetic district (seed 0) written once per session."""
    from core.synthetic import CRS_EPSG, make_district

    folder = tmp_path_factory.mktemp("district")
    d = make_district(0)
    files = DistrictFiles(
        district=d,
        folder=folder,
        laz=folder / "district.laz",
        stl=folder / "district.stl",
        ground_stl=folder / "district_ground.stl",
        crs=f"EPSG:{CRS_EPSG}",
    )
    d.write_las(files.laz)
    d.write_stl(files.stl)
    d.write_ground_stl(files.ground_stl)
    return files
