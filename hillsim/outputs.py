"""Every command's outputs as one set: checked before the work, written under temporary names, put in place at the end.

A command declares each output (a file or a folder) before it starts working::

    outputs = OutputSet("extend")
    csv_path = outputs.file("--out", args.out)        # checked now; returns a temporary path to write to
    png_path = outputs.file("--plot", args.plot)
    ... the work, writing into csv_path and png_path ...
    outputs.commit()                                   # renames everything into place
    # on an error: outputs.discard() removes every temporary file; nothing partial is left behind

``hillsim.cli`` creates one :class:`OutputSet` per command (``args.outputs``), commits it when the command returns
0 and discards it on any error, interrupt or termination. Python users can use it as a context manager
(``with OutputSet() as outputs:``: commit on success, discard on an exception).

What a declaration checks (before any work, so a bad path costs nothing): the path is not an existing folder (for a
file) or file (for a folder); the parent of a file exists and is a folder; the folder to write into is writable;
no other hillsim process is writing the same output (see below). Each failure is an
:class:`~hillchart.errors.InputError` naming the option and the path (the CLI exits 2).

Atomicity. A file is written as ``.STEM.hillsim-tmp-XXXX.SUFFIX`` beside its target and renamed onto it by
:meth:`OutputSet.commit` (``os.replace``: atomic on POSIX and Windows). A folder is written as a private temporary
folder beside it: when the target does not exist (or is empty) the temporary folder is renamed onto it in one step;
when it holds an earlier run, each new file is renamed into place and the earlier run's files that this run did not
write are removed (the earlier run's list is the hidden manifest ``.hillsim-outputs.json`` a committed folder keeps;
files hillsim did not write are never touched). Either way no interrupted or failed run leaves a truncated file, or
new files beside an earlier run's.

Locking. Each output holds an exclusive lock (``fcntl.flock`` on ``.NAME.hillsim-lock`` beside the target, removed on
release; the kernel releases it when a process dies, so a crash leaves no stale lock) from its declaration to the
commit. A second hillsim process declaring the same output fails at once with a message naming the option, the path
and the other process's id.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from hillchart.errors import InputError

try:  # POSIX; elsewhere the lock falls back to an exclusively created file
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

#: Manifest of a committed output folder: the relative paths of the files the run wrote.
MANIFEST = ".hillsim-outputs.json"
TMP_TAG = ".hillsim-tmp-"
LOCK_TAG = ".hillsim-lock"


class OutputLockedError(InputError):
    """Another process is writing the same output."""


@dataclass
class _Lock:
    path: Path
    handle: object = None

    def acquire(self, option: str, target: Path) -> None:
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | (0 if fcntl else os.O_EXCL), 0o644)
            except FileExistsError:  # pragma: no cover - Windows fallback
                raise OutputLockedError(self._busy(option, target, self._holder())) from None
            handle = os.fdopen(fd, "r+", encoding="ascii")
            if fcntl is None:  # pragma: no cover
                break
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = self._holder()
                handle.close()
                raise OutputLockedError(self._busy(option, target, holder)) from None
            # the holder before us may have removed the lock file after we opened it: lock the current file
            try:
                same = os.fstat(handle.fileno()).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            handle.close()
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        self.handle = handle

    def _holder(self) -> str:
        try:
            return self.path.read_text(encoding="ascii").strip() or "?"
        except OSError:
            return "?"

    @staticmethod
    def _busy(option: str, target: Path, holder: str) -> str:
        return (f"{option} {str(target)!r} is being written by another hillsim process (pid {holder}); wait for "
                "it to finish or choose another output")

    def release(self) -> None:
        if self.handle is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # while still holding the lock (see acquire)
        finally:
            self.handle.close()
            self.handle = None


@dataclass
class _Target:
    option: str
    final: Path
    temporary: Path
    kind: str  # "file" | "folder"
    lock: _Lock
    stale: tuple[str, ...] = ()
    created_parents: list[Path] = field(default_factory=list)


def _describe(option: str, path: Path) -> str:
    return f"{option} {str(path)!r}" if option else repr(str(path))


def _writable_folder(option: str, folder: Path, target: Path) -> None:
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{_describe(option, target)}: the folder {str(folder)!r} is read-only (no permission to "
                         "write there)")


class OutputSet:
    """The outputs of one command (see the module docstring).

    Parameters
    ----------
    command : str
        Named in messages (``"run"`` gives ``hillsim run``); informational only.
    """

    def __init__(self, command: str = ""):
        self.command = command
        self._targets: list[_Target] = []
        self._closed = False

    # -- declarations ------------------------------------------------------------------------------------------
    def file(self, option: str, path) -> Path | None:
        """Declare an output file; returns the temporary path to write to (None when ``path`` is None)."""
        if path is None:
            return None
        final = Path(path)
        self._check_new(option, final)
        if final.is_dir():
            raise InputError(f"{_describe(option, final)} is a folder; give a file name")
        parent = final.parent
        if not parent.exists():
            raise InputError(f"{_describe(option, final)}: the folder {str(parent)!r} does not exist")
        if not parent.is_dir():
            raise InputError(f"{_describe(option, final)}: {str(parent)!r} is not a folder")
        _writable_folder(option, parent, final)
        if final.exists() and not os.access(final, os.W_OK):
            raise InputError(f"{_describe(option, final)} exists and is read-only")
        lock = self._lock(option, final)
        try:
            # the suffix stays last: writers that choose the format by it (matplotlib's savefig) see the real one
            fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{final.stem}{TMP_TAG}", suffix=final.suffix)
        except OSError as exc:
            lock.release()
            raise InputError(f"{_describe(option, final)}: cannot write in {str(parent)!r}: {exc.strerror}") from None
        os.close(fd)
        self._targets.append(_Target(option, final, Path(tmp), "file", lock))
        return Path(tmp)

    def folder(self, option: str, path, *, stale: tuple[str, ...] = ()) -> Path:
        """Declare an output folder (created with its parents when missing); returns the temporary folder to write
        into. ``stale``: relative names this command may write; an earlier run's copy is removed when this run does
        not write it (for folders written before manifests existed)."""
        final = Path(path)
        self._check_new(option, final)
        if final.exists() and not final.is_dir():
            raise InputError(f"{_describe(option, final)} exists and is not a folder")
        existing = final.parent  # the temporary folder and the lock live beside the target
        while not existing.exists():
            if existing.parent == existing:  # pragma: no cover - the root always exists
                break
            existing = existing.parent
        if not existing.is_dir():
            raise InputError(f"{_describe(option, final)}: {str(existing)!r} is a file, not a folder")
        _writable_folder(option, existing, final)
        if final.is_dir():
            _writable_folder(option, final, final)
        created = []
        for parent in reversed(final.parents):
            if not parent.exists():
                try:
                    parent.mkdir()
                except OSError as exc:
                    raise InputError(f"{_describe(option, final)}: cannot create {str(parent)!r}: "
                                     f"{exc.strerror}") from None
                created.append(parent)
        try:
            lock = self._lock(option, final)
            try:
                tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=f".{final.name}{TMP_TAG}"))
            except OSError as exc:
                lock.release()
                raise InputError(f"{_describe(option, final)}: cannot write in {str(final.parent)!r}: "
                                 f"{exc.strerror}") from None
        except InputError:
            for folder in reversed(created):
                try:
                    folder.rmdir()
                except OSError:
                    break
            raise
        self._targets.append(_Target(option, final, tmp, "folder", lock, tuple(stale), created))
        return tmp

    def _check_new(self, option: str, final: Path) -> None:
        if self._closed:
            raise RuntimeError("this OutputSet was already committed or discarded")
        for t in self._targets:
            if _same(t.final, final):
                raise InputError(f"{_describe(option, final)} is also given as {t.option}; give distinct outputs")
            if _inside(final, t.final) or _inside(t.final, final):
                raise InputError(f"{_describe(option, final)} and {_describe(t.option, t.final)} overlap; give "
                                 "outputs outside each other")

    def _lock(self, option: str, final: Path) -> _Lock:
        lock = _Lock(final.parent / f".{final.name}{LOCK_TAG}")
        try:
            lock.acquire(option, final)
        except OutputLockedError:
            self.discard()
            raise
        except OSError as exc:
            self.discard()
            raise InputError(f"{_describe(option, final)}: cannot lock it ({exc.strerror})") from None
        return lock

    # -- end ---------------------------------------------------------------------------------------------------
    def commit(self) -> list[Path]:
        """Put every output in place; returns the final paths. Idempotent guard: a second call is an error."""
        if self._closed:
            raise RuntimeError("this OutputSet was already committed or discarded")
        done = []
        try:
            for t in self._targets:
                if t.kind == "file":
                    os.replace(t.temporary, t.final)
                else:
                    _commit_folder(t)
                done.append(t.final)
        finally:
            self._close(remove_temporaries=True)
        return done

    def discard(self) -> None:
        """Remove every temporary file and folder (and folders created for the outputs); release the locks."""
        if not self._closed:
            self._close(remove_temporaries=True, remove_created=True)

    def _close(self, *, remove_temporaries: bool, remove_created: bool = False) -> None:
        self._closed = True
        for t in reversed(self._targets):
            if remove_temporaries:
                if t.temporary.is_dir():
                    shutil.rmtree(t.temporary, ignore_errors=True)
                else:
                    t.temporary.unlink(missing_ok=True)
            t.lock.release()
            if remove_created:
                for folder in reversed(t.created_parents):
                    try:
                        folder.rmdir()
                    except OSError:
                        break

    @property
    def targets(self) -> dict[str, Path]:
        """``{option: final path}`` of the declared outputs."""
        return {t.option: t.final for t in self._targets}

    def __enter__(self) -> "OutputSet":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            if not self._closed:
                self.commit()
        else:
            self.discard()


def _same(a: Path, b: Path) -> bool:
    return os.path.abspath(a) == os.path.abspath(b)


def _inside(inner: Path, outer: Path) -> bool:
    inner_abs, outer_abs = Path(os.path.abspath(inner)), Path(os.path.abspath(outer))
    return inner_abs != outer_abs and outer_abs in inner_abs.parents


def _relative_files(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink())


def _commit_folder(t: _Target) -> None:
    written = [name for name in _relative_files(t.temporary) if name != MANIFEST]
    (t.temporary / MANIFEST).write_text(json.dumps({"files": written}, indent=1) + "\n", encoding="utf-8")
    try:
        os.replace(t.temporary, t.final)  # new or empty folder: one atomic rename
        return
    except OSError:
        pass  # the folder holds files: replace them one by one
    previous = []
    try:
        previous = json.loads((t.final / MANIFEST).read_text(encoding="utf-8")).get("files", [])
    except (OSError, ValueError, AttributeError):
        previous = []
    for name in written:
        dest = t.final / name
        dest.parent.mkdir(parents=True, exist_ok=True)
        if dest.is_dir() and not dest.is_symlink():
            shutil.rmtree(dest)
        os.replace(t.temporary / name, dest)
    new = set(written)
    for name in set(previous) | set(t.stale):
        if not isinstance(name, str) or name in new or Path(name).is_absolute() or ".." in Path(name).parts:
            continue
        (t.final / name).unlink(missing_ok=True)
    os.replace(t.temporary / MANIFEST, t.final / MANIFEST)  # last: the manifest marks the set complete
