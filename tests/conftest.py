import os

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")

# Property tests draw the same examples on every run (derandomize: examples from a fixed seed, and no example
# database), so a failure reproduces and a pass is not luck of the draw. Tests may ask for fewer examples.
settings.register_profile("bpmid", derandomize=True, max_examples=100, deadline=None, print_blob=True)
settings.load_profile("bpmid")
os.environ.setdefault("NUMBA_CACHE_DIR", os.path.join(os.path.dirname(__file__), "..", ".numba_cache"))

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


@pytest.fixture
def repo_root():
    return REPO


@pytest.fixture(scope="session")
def timed_small_study(tmp_path_factory):
    """``bpmid run`` of test_run's small study with timing on, computed once per pytest session and shared by
    every test that only reads its outputs (report, report in a browser). Tests must not write into it."""
    from _report_study import shared_study  # the same study the report, browser and figure tests read

    return shared_study(tmp_path_factory)[0]
