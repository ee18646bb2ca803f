"""The output discipline of every command: nothing half-written, no input replaced, nothing lost to a kill.

Single files
    :func:`write_bytes`, :func:`write_text` and :func:`staged_file` write a hidden temporary sibling
    (``.bpmid-tmp.<name>.*``) and rename it into place, so a reader sees the old file or the new one.

Folders
    :func:`staged_dir` stages a command's whole output in a hidden folder beside its destination (on the
    same file system: inside the destination when that is a mount point). When the destination does not
    exist yet the staged folder is renamed into place (one atomic step). Otherwise the files are switched
    in under a *journal* (:class:`Journal`): the journal lists every file that is new and every file whose
    old version is moved aside into a hidden backup, and it is written before the first file moves. Removing
    the journal is the commit. A command killed at any instant (SIGKILL included) therefore leaves either
    the old complete result, the new complete one, or a journal from which the next command that touches the
    folder (:func:`recover`) restores the old one. Files in the destination that the command does not write
    are left alone. Where a rename crosses file systems, a file is copied beside its destination and then
    renamed (copy-and-swap).

Inputs
    Inside :func:`guard_inputs` (every CLI command runs in one), every file a command reads through bpmid's
    readers is noted (:func:`note_input`); a write that would replace one of them -- the same resolved path
    or the same file through another name or a hard link -- is refused with an :class:`InputError` before
    anything is moved. Files this command wrote itself may be read and rewritten.

Signals
    :func:`sigterm_as_interrupt` turns SIGTERM (what ``kill``, ``timeout`` and CI cancellation send) and
    SIGHUP into :class:`Terminated`, a KeyboardInterrupt, so they roll back exactly like Ctrl-C. The commit
    and rollback steps run with these signals held back, so a second signal cannot cut them in half.

Leftovers of a killed command (hidden staging, backup and temporary files) are locked (``flock``) by the
process that made them while it lives; :func:`recover` removes only unlocked ones.
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import shutil
import signal
import tempfile
import threading
from pathlib import Path
from typing import Iterable, Iterator

from bpmid.errors import InputError

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX
    fcntl = None

STAGE_PREFIX = ".bpmid-stage."
UNDO_PREFIX = ".bpmid-undo."
RUN_UNDO_PREFIX = ".bpmid-run-undo."
TMP_PREFIX = ".bpmid-tmp."
JOURNAL_PREFIX = ".bpmid-journal."
#: hidden names this module may leave behind for :func:`recover` (never results)
HIDDEN_PREFIXES = (STAGE_PREFIX, UNDO_PREFIX, RUN_UNDO_PREFIX, TMP_PREFIX, JOURNAL_PREFIX)


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised like Ctrl-C so that every command rolls back the same way."""


# --------------------------------------------------------------------------------------------------
# plain messages for what the file system says
# --------------------------------------------------------------------------------------------------
def os_error(exc: OSError, where: str | Path, doing: str = "write") -> InputError:
    """An :class:`InputError` in plain words for an OSError met while writing ``where``."""
    code = exc.errno
    if code == errno.EROFS:
        msg = "the file system is read-only; choose an output folder on a writable disk (--out)"
    elif code in (errno.EACCES, errno.EPERM):
        msg = "no permission to write here; choose an output folder you can write to (--out)"
    elif code in (errno.ENOSPC, getattr(errno, "EDQUOT", -1)):
        msg = "the disk is full (or the quota is used up); nothing was written -- free space and run again"
    elif code == errno.EXDEV:
        msg = ("the output crosses file systems and could not be copied across either; choose an output folder "
               "on one disk")
    elif code in (errno.ENOTDIR, errno.EEXIST):
        msg = "a part of this path is a file, not a folder; choose another output path"
    elif code == errno.ENOENT:
        msg = "a folder on this path cannot be made here; choose another output path"
    else:
        msg = f"cannot {doing} it ({exc.strerror or exc})"
    # name what the user gave, not one of our hidden staging names
    name = exc.filename
    if name is None or any(pref in os.fspath(name) for pref in HIDDEN_PREFIXES):
        name = where
    return InputError(msg, path=name)


# --------------------------------------------------------------------------------------------------
# inputs a command must not replace
# --------------------------------------------------------------------------------------------------
class _Guard:
    def __init__(self):
        self.inputs: dict[str, str] = {}       # resolved path -> path as given
        self.ids: dict[tuple, str] = {}        # (st_dev, st_ino) -> path as given
        self.written: set[str] = set()         # resolved paths this command wrote
        self.hashes: dict[str, str] = {}       # sha256 of an input's content -> its path as recorded


_state = threading.local()


def _guard() -> _Guard | None:
    stack = getattr(_state, "guards", None)
    return stack[-1] if stack else None


@contextlib.contextmanager
def guard_inputs(inputs: Iterable[str | Path | None] = (), *, hashes: dict[str, str] | None = None) -> Iterator[None]:
    """Within this block every write refuses to replace a file read as input (see the module docstring).

    ``inputs`` are noted at once (for files the command names but reads later). ``hashes`` (sha256 -> the path as
    a result's provenance recorded it): a file with one of these contents is an input too, wherever it lies and
    however its path was spelled (a saved result's inputs may be recorded relative to another folder)."""
    stack = getattr(_state, "guards", None)
    if stack is None:
        stack = _state.guards = []
    stack.append(_Guard())
    stack[-1].hashes = dict(hashes or {})
    try:
        for p in inputs:
            if p is not None:
                note_input(p)
        yield
    finally:
        stack.pop()


def _resolved(path: str | Path) -> str:
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def note_input(path: str | Path) -> None:
    """Record ``path`` as an input of the running command (no effect outside :func:`guard_inputs`; files this
    command wrote itself are not inputs)."""
    g = _guard()
    if g is None:
        return
    real = _resolved(path)
    if real in g.written:
        return
    g.inputs.setdefault(real, str(path))
    with contextlib.suppress(OSError):
        st = os.stat(real)
        g.ids.setdefault((st.st_dev, st.st_ino), str(path))


def input_at(target: str | Path) -> str | None:
    """The input (as given) that writing ``target`` would replace, or None."""
    g = _guard()
    if g is None:
        return None
    real = _resolved(target)
    if real in g.written:
        return None
    if real in g.inputs:
        return g.inputs[real]
    hit = None
    with contextlib.suppress(OSError):
        st = os.stat(real)
        hit = g.ids.get((st.st_dev, st.st_ino))
    if hit is None and g.hashes and os.path.isfile(real):
        with contextlib.suppress(OSError):
            h = hashlib.sha256()
            with open(real, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
            hit = g.hashes.get(h.hexdigest())
    return hit


def check_not_input(target: str | Path, shown: str | Path | None = None) -> None:
    """InputError when writing ``target`` would replace an input of the running command."""
    hit = input_at(target)
    if hit is not None:
        raise InputError(f"the output would replace the input {hit}; nothing was written -- choose another "
                         "output folder or name (--out)", path=shown if shown is not None else target)


def check_writable(target: str | Path, key: str = "--out") -> None:
    """Before any work: refuse an output whose folder this user may not write into (the folder itself when
    ``target`` is one, else the folder it would go in, or the nearest existing folder above where the missing
    ones would be made), instead of reading and checking every input first and failing at the first write."""
    p = Path(os.path.abspath(target))
    d = p if p.is_dir() else p.parent
    while not d.exists() and d.parent != d:
        d = d.parent
    if d.is_dir() and not os.access(d, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into the folder {d} (no write permission, or a read-only file system); "
                         "nothing was read or written -- choose another output folder (or get write permission "
                         "there)", path=target, key=key)


def check_outputs_not_inputs(targets: Iterable[str | Path], inputs: Iterable[str | Path | None],
                             key: str = "--out") -> None:
    """Before any work: refuse when one of ``targets`` is (by resolved path or by file identity) one of
    ``inputs``, or lies in a folder this user may not write into. For commands whose output names are known up
    front."""
    for t in targets:
        check_writable(t, key)
    ins: dict[str, str] = {}
    ids: dict[tuple, str] = {}
    for p in inputs:
        if p is None:
            continue
        ins.setdefault(_resolved(p), str(p))
        with contextlib.suppress(OSError):
            st = os.stat(p)
            ids.setdefault((st.st_dev, st.st_ino), str(p))
    for t in targets:
        hit = ins.get(_resolved(t))
        if hit is None:
            with contextlib.suppress(OSError):
                st = os.stat(t)
                hit = ids.get((st.st_dev, st.st_ino))
        if hit is not None:
            raise InputError(f"the output would replace the input {hit}; choose another output folder or name",
                             path=t, key=key)


def file_head(path: str | Path, lines: int = 12) -> str:
    """The first ``lines`` lines of a text file ("" when it cannot be read): where a writer finds the mark that says
    a file in its output folder is its own to replace."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return "".join(fh.readline() for _ in range(lines))
    except OSError:
        return ""


def refuse_foreign_files(out_dir: Path, names: Iterable[str], ours, *, after: str = "", key: str = "--out") -> None:
    """InputError, before anything is written, when a file about to be written into ``out_dir`` is there and bpmid did
    not write it: ``ours(path) -> (bool, why not)`` judges each existing file by its own mark (a user's own ``m.csv``
    or ``main.c`` was replaced in silence)."""
    for name in names:
        f = Path(out_dir) / name
        if not f.is_file():
            continue
        ok, why = ours(f)
        if not ok:
            raise InputError(f"{name} is already in {out_dir} and bpmid did not write it ({why}): nothing was written; "
                             f"give another output folder, or move the file{after}", path=f, key=key)


def _is_bookkeeping(rel) -> bool:
    """Whether a staged file is bpmid's own bookkeeping rather than a result a user would call replaced."""
    return Path(rel).name.startswith(".bpmid")


def _note_written(path: str | Path) -> None:
    g = _guard()
    if g is not None:
        real = _resolved(path)
        g.written.add(real)
        g.inputs.pop(real, None)


# --------------------------------------------------------------------------------------------------
# signals
# --------------------------------------------------------------------------------------------------
_HELD = tuple(s for s in (getattr(signal, "SIGINT", None), getattr(signal, "SIGTERM", None),
                          getattr(signal, "SIGHUP", None)) if s is not None)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold back Ctrl-C, SIGTERM and SIGHUP (delivered after the block) so a commit or rollback runs whole."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


#: the signals :func:`sigterm_as_interrupt` turned into :class:`Terminated` in the running command
_RECEIVED: list[str] = []


def terminated_message(signal_name: str) -> str:
    """What a command says when a SIGTERM or SIGHUP ended it (exit 143)."""
    return f"terminated ({signal_name}); nothing was left half-written"


def termination_received() -> str | None:
    """The name of the SIGTERM or SIGHUP the running command received (None: none). A library's compiled code can
    turn the :class:`Terminated` raised inside one of its callbacks into an error of its own (matplotlib's renderer
    raised "ValueError: Invalid bounding box"): the command still ends as terminated, not as an internal error."""
    return _RECEIVED[-1] if _RECEIVED else None


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block SIGTERM and SIGHUP raise :class:`Terminated` (a KeyboardInterrupt) in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, _frame):
        _RECEIVED.append(signal.Signals(signum).name)
        raise Terminated(signal.Signals(signum).name)

    _RECEIVED.clear()

    previous = {}
    for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)):
        if s is not None:
            with contextlib.suppress(ValueError, OSError):
                previous[s] = signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(s, h if h is not None else signal.SIG_DFL)


# --------------------------------------------------------------------------------------------------
# locks: a hidden file or folder is "live" while the process that made it holds its flock
# --------------------------------------------------------------------------------------------------
def _lock_fd(fd: int) -> None:
    if fcntl is not None:
        # a file system without locks (some network mounts): the file works, recover() just never takes it
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


def _is_live(path: Path) -> bool:
    """True when another process holds the lock of ``path`` (its maker is still running)."""
    if fcntl is None:  # pragma: no cover
        return True
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


class _LockedDir:
    """A hidden folder made with ``mkdtemp`` and held locked until :meth:`release`."""

    def __init__(self, prefix: str, parent: Path):
        self.path = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        self.fd = os.open(self.path, os.O_RDONLY)
        _lock_fd(self.fd)

    def release(self, remove: bool = True) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        if remove:
            shutil.rmtree(self.path, ignore_errors=True)


#: how long a command waits for another one's hold on its output folder before it is refused (s)
COMMIT_WAIT_S = 10.0
_HELD_FOLDERS: dict[str, list] = {}  # resolved folder -> [fd, depth] of the folder locks this process holds


@contextlib.contextmanager
def folder_lock(folder: str | Path, wait_s: float = 10.0,
                advice: str = "wait for it to finish or choose another output folder (--out)") -> Iterator[None]:
    """Hold the folder ``folder`` for one writer: a second bpmid command that switches files into it waits up to
    ``wait_s`` seconds, then is refused (InputError, ending with ``advice``: what to do) instead of mixing its
    files with ours. Re-entrant within one process (a run's stages may write into the folder the run holds)."""
    key = _resolved(folder)
    held = _HELD_FOLDERS.get(key)
    if held is not None:
        held[1] += 1
        try:
            yield
        finally:
            held[1] -= 1
        return
    try:
        fd = os.open(key, os.O_RDONLY)
    except OSError as exc:
        raise os_error(exc, folder, "open") from exc
    try:
        if fcntl is not None:
            deadline = _now() + wait_s
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if _now() >= deadline:
                        raise InputError(f"another bpmid command is writing into this folder; {advice}",
                                         path=folder) from None
                    import time

                    time.sleep(0.05)
                except OSError:
                    break  # a file system without locks
        _HELD_FOLDERS[key] = [fd, 1]
        yield
    finally:
        if _HELD_FOLDERS.get(key, [None])[0] == fd:
            del _HELD_FOLDERS[key]
        os.close(fd)  # closing the only descriptor releases the lock


def _now() -> float:
    import time

    return time.monotonic()


def _umask() -> int:
    """The process umask (read by setting it and putting it back)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _umask_mode() -> int:
    """0666 less the process umask: the mode an ordinary ``open()`` would give a new file."""
    return 0o666 & ~_umask()


def _ensure_parent(path: Path) -> None:
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise InputError("output folder is not a folder", path=parent)
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise os_error(exc, parent) from exc


def _check_file_target(path: Path) -> None:
    if path.is_dir():
        raise InputError("the output is an existing folder; give a file name", path=path)
    check_not_input(path)


# --------------------------------------------------------------------------------------------------
# single files
# --------------------------------------------------------------------------------------------------
def _replace_into(tmp: Path, path: Path) -> None:
    try:
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise os_error(exc, path) from exc
        _copy_swap(tmp, path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Atomically write ``data`` to ``path`` (temporary sibling + rename); refuses to replace an input."""
    path = Path(path)
    _check_file_target(path)
    _ensure_parent(path)
    if path.name.startswith(TMP_PREFIX) and path.is_file() and not path.is_symlink():
        # a temporary of staged_file (the caller renames it into place): written in place, so the file its maker
        # holds locked stays the one on disk; a new file renamed over it would be unlocked, and another
        # command's recover() would remove it as a leftover of a killed command
        try:
            with open(path, "r+b") as fh:
                fh.truncate()
                fh.write(data)
        except OSError as exc:
            raise os_error(exc, path) from exc
        return path
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise os_error(exc, path) from exc
    try:
        _lock_fd(fd)
        with os.fdopen(fd, "wb", closefd=False) as fh:
            fh.write(data)
        os.chmod(tmp, _umask_mode())  # mkstemp makes 0600 files; results are meant to be shared
        with signals_held():
            _replace_into(Path(tmp), path)
            _note_written(path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise os_error(exc, path) from exc
        raise
    finally:
        os.close(fd)
    return path


def write_text(path: str | Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


@contextlib.contextmanager
def staged_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path; on success it is renamed to ``path``, on failure removed.

    For writers that need a file name (``fig.savefig(tmp)``, ``df.to_csv(tmp)``).
    """
    path = Path(path)
    _check_file_target(path)
    _ensure_parent(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{path.stem}.", suffix=path.suffix, dir=path.parent)
    except OSError as exc:
        raise os_error(exc, path) from exc
    tmp = Path(tmp)
    try:
        _lock_fd(fd)
        yield tmp
        os.chmod(tmp, _umask_mode())
        check_not_input(path)
        with signals_held():
            _replace_into(tmp, path)
            _note_written(path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    finally:
        os.close(fd)


def _copy_swap(src: Path, dst: Path) -> None:
    """Move ``src`` to ``dst`` across file systems: copy beside ``dst``, then rename into place."""
    fd, tmp = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{dst.name}.", suffix=".tmp", dir=dst.parent)
    try:
        _lock_fd(fd)
        with open(src, "rb") as fi, os.fdopen(fd, "wb", closefd=False) as fo:
            shutil.copyfileobj(fi, fo, 1 << 20)
        shutil.copymode(src, tmp)
        os.replace(tmp, dst)
        os.unlink(src)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    finally:
        os.close(fd)


def _move(src: Path, dst: Path) -> None:
    try:
        os.replace(src, dst)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
        _copy_swap(src, dst)


# --------------------------------------------------------------------------------------------------
# the journal
# --------------------------------------------------------------------------------------------------
class Journal:
    """Undo log for a command that changes files in the existing folder ``out``.

    Two ways to use it:

    - *moves* (:func:`staged_dir`): :meth:`plan` lists the files about to be switched in; :meth:`switch`
      moves each old version into the backup and the new one into place.
    - *in place* (``bpmid run``): :meth:`snapshot` copies the current versions of the files the command may
      rewrite into the backup and records every name in ``out``; the command then writes in place, and a
      rollback removes every name that was not there and puts the copies back.

    :meth:`commit` removes the journal (the commit point), then the backup; :meth:`rollback` undoes.
    :func:`recover` does the same rollback for the journal of a process that died.
    """

    def __init__(self, out: str | Path):
        self.out = Path(os.path.abspath(out))
        self.backup: _LockedDir | None = None
        self.path: Path | None = None
        self.fd: int | None = None
        self.data: dict = {"version": 1, "pid": os.getpid(), "out": str(self.out), "backup": None,
                           "saved": [], "new": [], "new_dirs": [], "before": None}

    # -- writing the journal --------------------------------------------------------------------
    def _write(self) -> None:
        text = json.dumps(self.data)
        if self.fd is None:
            fd, tmp = tempfile.mkstemp(prefix=JOURNAL_PREFIX, suffix=".json.tmp", dir=self.out)
            _lock_fd(fd)  # locked before it has its final name: never seen unlocked by recover()
            os.write(fd, text.encode())
            os.fsync(fd)
            path = Path(tmp[: -len(".tmp")])
            os.replace(tmp, path)
            self.fd, self.path = fd, path
        else:  # rewrite in place under the same lock (the lock belongs to the open file)
            os.lseek(self.fd, 0, os.SEEK_SET)
            os.ftruncate(self.fd, 0)
            os.write(self.fd, text.encode())
            os.fsync(self.fd)

    def _make_backup(self, prefix: str = UNDO_PREFIX) -> Path:
        self.backup = _LockedDir(prefix, self.out)
        self.data["backup"] = self.backup.path.name
        return self.backup.path

    # -- in place ---------------------------------------------------------------------------------
    def snapshot(self, own: Iterable[str], backup_prefix: str = RUN_UNDO_PREFIX,
                 walk: Iterable[str] | None = None) -> None:
        """Copy the files ``own`` (relative to ``out``) into the backup, record the names now in ``out``, then
        write the journal. Nothing in ``out`` is changed.

        ``walk``: the subfolders the command writes into (recorded whole); other subfolders are recorded by name
        only, so a folder full of unrelated data (``--out .``) costs nothing. None records everything."""
        before: list[str] = []
        walk = None if walk is None else [str(w) for w in walk]
        roots = [self.out] if walk is None else [self.out / w for w in walk
                                                 if (self.out / w).is_dir() and not (self.out / w).is_symlink()]
        if walk is not None:
            before += [p.name for p in self.out.iterdir() if not p.name.startswith(HIDDEN_PREFIXES)]
        for top in roots:
            for root, dirs, files in os.walk(top):
                rel = Path(root).relative_to(self.out)
                dirs[:] = [d for d in dirs if not d.startswith(HIDDEN_PREFIXES)]
                before += [str(rel / n) for n in dirs + files if not n.startswith(HIDDEN_PREFIXES)]
        backup = self._make_backup(backup_prefix)
        saved = []
        for rel in own:
            src, dst = self.out / rel, backup / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)
            saved.append(str(rel))
        self.data.update(before=before, saved=saved, walk=walk)
        self._write()

    @classmethod
    def new_folder(cls, out: str | Path, created_levels: int = 1) -> "Journal":
        """Make the folder ``out`` (which does not exist) with an in-place journal already inside it: the folder
        is made as a hidden, locked staging folder beside ``out``, the journal written into it, and then renamed
        to ``out``, so that no instant shows ``out`` without its journal. A rollback removes ``out`` and the
        ``created_levels - 1`` parents made for it, when they are empty (levels, not paths: a copied folder
        recovers on its own)."""
        out = Path(os.path.abspath(out))
        area = _LockedDir(STAGE_PREFIX, out.parent)
        try:
            journal = cls(area.path)
            journal.data["out"] = str(out)  # where the folder will be: the journal is for it, not the stage
            journal.data["created_levels"] = int(created_levels)
            journal.snapshot([])
            os.chmod(area.path, 0o777 & ~_umask())  # mkdtemp made it 0700; the result is an ordinary folder
            os.rename(area.path, out)
        except BaseException:
            journal_fd = locals().get("journal")
            if journal_fd is not None:
                journal_fd._close()
                if journal_fd.backup is not None:
                    journal_fd.backup.release(remove=False)
            area.release(remove=True)
            raise
        area.release(remove=False)
        journal.out = out
        journal.path = out / journal.path.name
        journal.backup.path = out / journal.backup.path.name
        return journal

    # -- moves ------------------------------------------------------------------------------------
    def plan(self, files: list[str], new_dirs: list[str]) -> None:
        """Record the switch of ``files`` (relative paths) before the first one moves."""
        self._make_backup()
        self.data["saved"] = [r for r in files if os.path.lexists(self.out / r)]
        self.data["new"] = [r for r in files if not os.path.lexists(self.out / r)]
        self.data["new_dirs"] = list(new_dirs)
        self._write()

    def switch(self, stage: Path) -> None:
        """Move every planned file from ``stage`` into ``out`` (old versions into the backup)."""
        backup = self.backup.path
        for rel in self.data["new_dirs"]:
            (self.out / rel).mkdir(parents=True, exist_ok=True)
        for rel in self.data["saved"] + self.data["new"]:
            dst = self.out / rel
            if rel in self.data["saved"]:
                (backup / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(dst, backup / rel)
            _move(stage / rel, dst)

    # -- ends ---------------------------------------------------------------------------------------
    def commit(self) -> None:
        self._end(roll_back=False)

    def rollback(self) -> None:
        self._end(roll_back=True)

    def _end(self, *, roll_back: bool) -> None:
        """Roll the files back (or keep them), then remove the journal: removing it is the commit point."""
        with signals_held():
            if self.path is not None:
                if roll_back:
                    _rollback(self.out, self.data)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.path)
            self._close()
            if self.backup is not None:
                self.backup.release()
                self.backup = None

    def _close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def _rollback(out: Path, data: dict) -> None:
    """Put ``out`` back as the journal ``data`` says it was (idempotent: a rollback cut short can be rerun)."""
    backup = out / data["backup"] if data.get("backup") else None
    before = data.get("before")
    if before is not None:  # in place: every name that was not there goes
        keep = set(before)
        walk = data.get("walk")
        if walk is None:
            _prune(out, out, keep)
        else:
            for p in list(out.iterdir()) if out.is_dir() else []:
                if not p.name.startswith(HIDDEN_PREFIXES) and p.name not in keep:
                    _remove(p)
            for w in walk:
                p = out / w
                if w in keep and p.is_dir() and not p.is_symlink():
                    _prune(out, p, keep)
    for rel in data.get("new", []):
        with contextlib.suppress(OSError):
            (out / rel).unlink()
    for rel in data.get("saved", []):
        if backup is not None and os.path.lexists(backup / rel):
            with contextlib.suppress(OSError):
                (out / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(backup / rel, out / rel)
    for rel in sorted(data.get("new_dirs", []), key=lambda r: -len(Path(r).parts)):
        with contextlib.suppress(OSError):
            (out / rel).rmdir()
    if backup is not None:
        shutil.rmtree(backup, ignore_errors=True)


def _prune(out: Path, top: Path, keep: set[str]) -> None:
    """Remove under ``top`` every name (relative to ``out``) not in ``keep``, and half-written temporary files."""
    for root, dirs, files in os.walk(top, topdown=False):
        here = Path(root)
        rel = here.relative_to(out)
        if any(part.startswith(HIDDEN_PREFIXES) for part in rel.parts):
            continue
        for n in files:
            if n.startswith(TMP_PREFIX) and rel.parts and not _is_live(here / n):
                with contextlib.suppress(OSError):  # a half-written file in a subfolder
                    (here / n).unlink()
            elif not n.startswith(HIDDEN_PREFIXES) and str(rel / n) not in keep:
                with contextlib.suppress(OSError):
                    (here / n).unlink()
        for n in dirs:
            if not n.startswith(HIDDEN_PREFIXES) and str(rel / n) not in keep:
                _remove(here / n)


def recover(folder: str | Path) -> list[str]:
    """Finish what a killed command left in ``folder`` (and beside it): roll back every journal whose process
    is gone, then remove its staging, backup and temporary files. Returns what was done, in words.

    Safe to call at any time: hidden files of a command that is still running (locked) are left alone."""
    folder = Path(folder)
    done: list[str] = []
    parent = folder.parent if str(folder.parent) else Path(".")
    with signals_held():
        # staging folders beside the destination (the destination did not exist when the command started)
        with contextlib.suppress(OSError):
            for p in parent.iterdir():
                if p.name.startswith((STAGE_PREFIX, TMP_PREFIX)) and not _is_live(p):
                    _remove(p)
                    done.append(f"removed {p.name} (a staging area of a command that was killed)")
        if not folder.is_dir():
            return done
        try:
            entries = list(folder.iterdir())
        except OSError:
            return done
        for j in sorted(p for p in entries if p.name.startswith(JOURNAL_PREFIX)):
            if j.name.endswith(".tmp"):
                if not _is_live(j):
                    _remove(j)
                continue
            if _is_live(j):
                continue
            try:
                data = json.loads(j.read_text("utf-8"))
            except (OSError, ValueError):
                data = None
            if not _journal_of(data, folder):
                # not a journal this folder's commands wrote (copied or moved here, or made by hand): act on
                # nothing it says -- a journal names files to delete
                done.append(f"left {j.name} alone: it is not a journal of {folder}")
                continue
            _rollback(folder, data)
            done.append(f"rolled back an interrupted write in {folder} (journal {j.name})")
            with contextlib.suppress(OSError):
                j.unlink()
            if isinstance(data.get("created_levels"), int):
                # the folder (and the parents made for it) did not exist before: remove them when empty
                levels = max(0, min(int(data["created_levels"]), len(folder.parts) - 1))
                _remove_empty([folder, *list(folder.parents)[: max(levels - 1, 0)]])
        if not folder.is_dir():
            return done
        for p in entries:
            if p.name.startswith((STAGE_PREFIX, UNDO_PREFIX, RUN_UNDO_PREFIX, TMP_PREFIX)) and p.exists() \
                    and not _is_live(p):
                _remove(p)
                done.append(f"removed {p.name} (left by a command that was killed)")
    return done


def _safe_rel(rel) -> bool:
    """A relative path that stays inside its folder (no absolute path, no ``..``)."""
    if not isinstance(rel, str) or not rel or os.path.isabs(rel):
        return False
    return ".." not in Path(rel).parts


def _journal_of(data, folder: Path) -> bool:
    """True when ``data`` is a well-formed journal written for ``folder`` itself (by path), naming only files
    inside it."""
    if not isinstance(data, dict) or data.get("version") != 1:
        return False
    out = data.get("out")
    if not isinstance(out, str) or (os.path.abspath(out) != os.path.abspath(folder)
                                    and _resolved(out) != _resolved(folder)):
        return False
    backup = data.get("backup")
    if backup is not None and (not isinstance(backup, str) or "/" in backup or os.sep in backup
                               or not backup.startswith((UNDO_PREFIX, RUN_UNDO_PREFIX))):
        return False
    for key in ("saved", "new", "new_dirs", "before", "walk"):
        v = data.get(key)
        if v is None:
            continue
        if not isinstance(v, list) or not all(_safe_rel(r) for r in v):
            return False
    lv = data.get("created_levels")
    return lv is None or (isinstance(lv, int) and not isinstance(lv, bool) and 0 <= lv <= 64)


def _remove_empty(dirs) -> None:
    """rmdir every folder of ``dirs`` that is empty (hidden leftovers of ours first), deepest first."""
    for d in sorted((Path(x) for x in dirs), key=lambda p: -len(p.parts)):
        with contextlib.suppress(OSError):
            for p in d.iterdir():
                if p.name.startswith(HIDDEN_PREFIXES) and not _is_live(p):
                    _remove(p)
            d.rmdir()


def _remove(p: Path) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            p.unlink()


# --------------------------------------------------------------------------------------------------
# folders
# --------------------------------------------------------------------------------------------------
def _same_device(a: Path, b: Path) -> bool:
    try:
        return os.stat(a).st_dev == os.stat(b).st_dev
    except OSError:
        return False


def _stage_area(out: Path) -> tuple[_LockedDir, bool]:
    """A locked staging folder for ``out``: beside it when that is on the same file system, else inside it.
    Returns (folder, inside)."""
    parent = out.parent
    exists = out.is_dir()
    if not exists or _same_device(parent, out):
        try:
            return _LockedDir(STAGE_PREFIX, parent), False
        except OSError as exc:
            if not exists:
                raise os_error(exc, out) from exc
            # the parent is not writable (``--out .`` in a read-only parent): stage inside the destination
    try:
        return _LockedDir(STAGE_PREFIX, out), True
    except OSError as exc:
        raise os_error(exc, out) from exc


def _staged_files(stage: Path) -> tuple[list[str], list[str]]:
    files, dirs = [], []
    for root, dnames, fnames in os.walk(stage):
        rel = Path(root).relative_to(stage)
        dirs += [str(rel / d) for d in dnames]
        files += [str(rel / f) for f in fnames]
    return sorted(files), sorted(dirs)


@contextlib.contextmanager
def staged_dir(out_dir: str | Path) -> Iterator[Path]:
    """Yield a temporary folder; on success its contents are switched into ``out_dir`` (see the module
    docstring: atomically when ``out_dir`` is new, else under a journal); on failure it is removed.

    Files already in ``out_dir`` that the command does not write are left alone. A file that would replace an
    input of the running command (:func:`guard_inputs`) is refused before anything moves.
    """
    given = Path(out_dir)
    if str(out_dir) == "":
        raise InputError("the output folder is empty text; give a folder name", key="--out")
    if given.exists() and not given.is_dir():
        raise InputError("--out must be a folder, found a file", path=given)
    out = Path(_resolved(given))  # a symlinked --out: stage beside where the files will really go
    for anc in out.parents:  # the nearest existing ancestor must be a folder
        if anc.exists():
            if not anc.is_dir():
                raise InputError("a part of the output path is a file, not a folder; choose another output path",
                                 path=anc)
            break
    recover(out)
    created: list[Path] = []
    top = out
    while not top.parent.exists() and top.parent != top:
        top = top.parent
    if top != out or not out.exists():
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise os_error(exc, given) from exc
        if top != out:
            created.append(top)
    if out.parent.exists() and not out.parent.is_dir():
        raise InputError("a part of the output path is a file, not a folder", path=given)
    area, inside = _stage_area(out)
    stage = area.path
    try:
        yield stage
        files, dirs = _staged_files(stage)
        for rel in files:
            target = out / rel
            check_not_input(target, given / rel)
            if target.is_dir() and not target.is_symlink():
                raise InputError("the output would replace a folder of the same name; choose another --out",
                                 path=given / rel)
        replaced = [rel for rel in files if (out / rel).is_file() and not _is_bookkeeping(rel)]
        lock = contextlib.ExitStack()
        if out.exists():  # one writer at a time (waits for another command's commit, not for its work)
            lock.enter_context(folder_lock(out, COMMIT_WAIT_S))
        with lock, signals_held():
            if not out.exists() and not inside:
                os.chmod(stage, 0o777 & ~_umask())  # mkdtemp made it 0700; the result is an ordinary folder
                try:
                    os.rename(stage, out)
                    area.release(remove=False)
                    for rel in files:
                        _note_written(out / rel)
                    return
                except OSError as exc:
                    if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.EXDEV):
                        raise os_error(exc, given) from exc
                    out.mkdir(parents=True, exist_ok=True)  # someone made it meanwhile: switch in file by file
            elif not out.exists():
                out.mkdir(parents=True, exist_ok=True)
            journal = Journal(out)
            try:
                journal.plan(files, [d for d in dirs if not (out / d).is_dir()])
                journal.switch(stage)
            except BaseException as exc:
                journal.rollback()
                if isinstance(exc, OSError):
                    raise os_error(exc, given) from exc
                raise
            journal.commit()
            for rel in files:
                _note_written(out / rel)
        if replaced:
            from bpmid.progress import line

            names = ", ".join(str(r) for r in replaced[:3]) + (f" and {len(replaced) - 3} more" if len(replaced) > 3
                                                                else "")
            written = set(files)
            others = any(p.is_file() and not _is_bookkeeping(p.name) and str(p.relative_to(out)) not in written
                         for p in out.rglob("*"))
            line(f"replaced {len(replaced)} file(s) already in {given} with this run's ({names})"
                 + ("; the folder's other files are left as they were" if others else ""))
    except BaseException:
        for c in created:
            shutil.rmtree(c, ignore_errors=True)
        raise
    finally:
        area.release(remove=True)
