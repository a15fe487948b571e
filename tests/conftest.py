import os
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, settings

from .images import lidar_scan

# No "explain" phase: it traces every line the failing example runs, and with Numba
# dispatchers in the trace it took 15.7 GB before reporting one failure of tests/test_hostile.py.
PHASES = [Phase.explicit, Phase.reuse, Phase.generate, Phase.target, Phase.shrink]

settings.register_profile(
    "ci",
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
    phases=PHASES,
)
settings.load_profile("ci")

ROOT = Path(__file__).resolve().parents[1]

# A run started in the background inherits SIGINT ignored, and so would every process the tests
# start; the tests of Ctrl-C need it delivered as a terminal delivers it.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def data_dir() -> Path | None:
    env = os.environ.get("RANGEMESH_DATA")
    candidates = [Path(env)] if env else []
    candidates += [ROOT.parent / "shared" / "data", ROOT / "shared" / "data"]
    for c in candidates:
        if (c / "README.md").exists():
            return c
    return None


@pytest.fixture(scope="session")
def shared_data():
    d = data_dir()
    if d is None:
        if os.environ.get("RANGEMESH_REQUIRE_DATA"):
            pytest.fail("../shared/data not found and RANGEMESH_REQUIRE_DATA is set")
        pytest.skip("../shared/data not found (set RANGEMESH_DATA)")
    return d


@pytest.fixture(scope="session")
def data_or_crops():
    """The data folder, or None: then tests take the committed crops (tests/images.load_or_crop)."""
    d = data_dir()
    if d is None and os.environ.get("RANGEMESH_REQUIRE_DATA"):
        pytest.fail("../shared/data not found and RANGEMESH_REQUIRE_DATA is set")
    return d


@pytest.fixture(scope="session")
def open3d():
    """The real Open3D; CI (RANGEMESH_REQUIRE_OPEN3D) fails rather than skips without it."""
    try:
        import open3d
    except ImportError as exc:  # not installed, or its system libraries (libusb-1.0) missing
        if os.environ.get("RANGEMESH_REQUIRE_OPEN3D"):
            pytest.fail(f"Open3D cannot be imported and RANGEMESH_REQUIRE_OPEN3D is set ({exc})")
        pytest.skip(f"Open3D cannot be imported ({exc}); pip install 'rangemesh[open3d]'")
    return open3d


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# The inputs of the hostile-input reports' tests, in several modules: the chair crop and a
# synthetic OS1-64 scan.
CROPS = Path(__file__).parent / "data" / "crops.npz"


@pytest.fixture(scope="module")
def chair():
    """A 96x96 uint8 crop of the Odetics chair (background 0)."""
    return np.load(CROPS)["chair"]


@pytest.fixture
def chair_file(tmp_path, chair):
    p = tmp_path / "chair.npy"
    np.save(p, chair)
    return p


@pytest.fixture(scope="module")
def os1(tmp_path_factory):
    """A scan laid out as the shared OS1-64 scan (64 x 2048, the same files): tests/images.py."""
    return lidar_scan(tmp_path_factory.mktemp("os1"))


@pytest.fixture(scope="module")
def beams_file(os1):
    return os1["beams"]


@pytest.fixture
def scan_file(os1, tmp_path):
    dst = tmp_path / "scan.npy"
    shutil.copy(os1["range"], dst)
    return dst
