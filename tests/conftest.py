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


# ---------------------------------------------------------------------------------------------------------------
# pytest-xdist (the README runs `pytest -n 2`): a worker computes a module or session fixture for the tests it
# runs, so tests that share such a fixture of ours (directly or through another one) run on one worker, as one
# work unit; every other test is scheduled on its own. The workers know the fixtures, the controller schedules:
# each worker writes {node id: group} after collection into a folder the controller names, and the controller's
# scheduler (LoadScopeScheduling, largest unit first) reads it. (xdist's own `--dist loadgroup` renames node ids,
# which pytest 9.2 no longer allows.) Without xdist none of this runs.
# ---------------------------------------------------------------------------------------------------------------
_TESTS = os.path.dirname(os.path.abspath(__file__))
_GROUPS_KEY = "bpmid_xdist_groups"


def _shared_fixtures(item):
    """'<module or session>:<fixture>' for every fixture of ours wider than a function that ``item`` uses."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return []
    keys = []
    for name in info.names_closure:
        for fd in info.name2fixturedefs.get(name, ()):
            if fd.scope == "function":
                continue
            src = getattr(getattr(fd.func, "__code__", None), "co_filename", "")
            if not os.path.abspath(src).startswith(_TESTS + os.sep):
                continue  # pytest's own (tmp_path_factory, ...) are cheap
            where = "session" if fd.scope == "session" else os.path.basename(src)
            keys.append(f"{where}:{name}")
    return keys


def fixture_groups(items) -> dict:
    """{node id: group} for the tests that share a wider fixture of ours (union of tests linked by any)."""
    parent: dict = {}

    def find(k):
        while parent.setdefault(k, k) != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    per_item = [(item.nodeid, _shared_fixtures(item)) for item in items]
    for _, keys in per_item:
        for k in keys[1:]:
            parent[find(k)] = find(keys[0])
    return {nodeid: "group:" + find(keys[0]) for nodeid, keys in per_item if keys}


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    folder = getattr(config, "workerinput", {}).get(_GROUPS_KEY)
    if folder:  # an xdist worker: hand the groups to the controller
        import json

        path = os.path.join(folder, config.workerinput["workerid"] + ".json")
        with open(path + ".tmp", "w") as f:
            json.dump(fixture_groups(items), f)
        os.replace(path + ".tmp", path)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    import tempfile

    cfg = node.config
    if not hasattr(cfg, "_bpmid_groups_dir"):
        cfg._bpmid_groups_dir = tempfile.mkdtemp(prefix="bpmid-xdist-groups-")
    node.workerinput[_GROUPS_KEY] = cfg._bpmid_groups_dir


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    """On each xdist worker (``-n 2``), compile half of the kernels most tests use into numba's shared cache
    (``tests/_warm_numba.py``: gw0 the closed loop and the baselines, gw1 the open-loop VBMM, the effects, the
    rivals and the relaxation kernels),
    then wait for the other half, so that no test compiles a kernel the other worker compiles too. It decides
    nothing: a kernel left out is compiled where it is needed, and the wait ends after 120 s whatever happens."""
    wi = getattr(session.config, "workerinput", None)
    folder = (wi or {}).get(_GROUPS_KEY)
    if not wi or not folder or os.environ.get("BPMID_NO_WARM"):
        return
    import time

    from _warm_numba import PARTS, warm

    count = int(wi.get("workercount", 1))
    index = int(str(wi.get("workerid", "gw0"))[2:] or 0)
    mine = [p for i, p in enumerate(PARTS) if i % count == index]
    for part in mine:
        warm(part)
    open(os.path.join(folder, f"warm-{index}.done"), "w").close()
    others = [os.path.join(folder, f"warm-{i}.done") for i in range(min(count, len(PARTS))) if i != index]
    deadline = time.monotonic() + 120.0
    while any(not os.path.exists(f) for f in others) and time.monotonic() < deadline:
        time.sleep(0.05)


def pytest_unconfigure(config):
    folder = getattr(config, "_bpmid_groups_dir", None)
    if folder:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    if config.getvalue("dist") != "load":  # another --dist asked for explicitly: xdist's own
        return None
    import glob
    import json

    from xdist.scheduler import LoadScopeScheduling

    class SharedFixtureScheduling(LoadScopeScheduling):
        """xdist's load scheduling, except that the tests of one fixture group are one unit of work."""

        _groups = None

        def _split_scope(self, nodeid):
            if self._groups is None:
                self._groups = {}
                for path in glob.glob(os.path.join(getattr(config, "_bpmid_groups_dir", ""), "*.json")):
                    with open(path) as f:
                        self._groups.update(json.load(f))
            return self._groups.get(nodeid, nodeid)

    return SharedFixtureScheduling(config, log)

