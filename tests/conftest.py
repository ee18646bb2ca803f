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
