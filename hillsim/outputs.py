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
no other hillsim process is writing the same output (see below); the path is not empty; the output is not one of
the command's inputs, nor a folder whose commit would replace or remove one (``identify --data r/timeseries.csv
--out r``: the CLI passes every argument naming an existing path as an input). Each failure is an
:class:`~hillchart.errors.InputError` naming the option and the path (the CLI exits 2). Before the commit, an output
that would replace a file the command read (found by a ``sys.audit`` hook on ``open``: ``extend c --out
c/flow.csv``) is refused too, and nothing is written.

Special targets. A device, FIFO or socket (``/dev/null``, ``/dev/stdout``) is written in place, never replaced by a
regular file; a symbolic link is followed (its target is replaced, the link kept). Files get the mode the umask
asks for (or the mode of the file they replace), folders too. Temporaries an earlier run left behind (killed by
SIGKILL or a power cut) are removed by the next run that takes the output's lock.

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
import re
import shutil
import stat
import sys
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


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


class _Reads:
    """Paths opened for reading while a command runs (``sys.audit`` "open" events), so that an output that would
    replace a file the command read (``hillsim extend c --out c/flow.csv``) is refused before it is put in place.
    One audit hook per process (hooks cannot be removed); it records only while a set is recording."""

    installed = False
    active: list[set] = []

    @classmethod
    def start(cls) -> set:
        if not cls.installed:
            sys.addaudithook(cls._hook)
            cls.installed = True
        paths: set = set()
        cls.active.append(paths)
        return paths

    @classmethod
    def stop(cls, paths: set) -> None:
        if any(p is paths for p in cls.active):
            cls.active[:] = [p for p in cls.active if p is not paths]

    @classmethod
    def _hook(cls, event, args):
        if event != "open" or not cls.active:
            return
        try:
            path, mode, flags = args[0], args[1], args[2]
            if isinstance(path, int):
                return
            if isinstance(mode, str):
                if any(c in mode for c in "wax+"):
                    return
            elif isinstance(flags, int) and flags & (os.O_WRONLY | os.O_RDWR):
                return
            name = os.path.realpath(os.fsdecode(path))
        except Exception:  # an audit hook must never break the open it observes
            return
        for paths in cls.active:
            paths.add(name)


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
                if holder == str(os.getpid()):
                    raise OutputLockedError(f"{option} {str(target)!r} is the same file as another output of this "
                                            "command (through a link); give distinct outputs") from None
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
    final: Path  # as given (messages)
    temporary: Path
    kind: str  # "file" | "folder" | "direct" (a device, FIFO or socket: written in place, nothing to commit)
    lock: _Lock | None
    stale: tuple[str, ...] = ()
    created_parents: list[Path] = field(default_factory=list)
    real: Path | None = None  # ``final`` with links resolved: where the temporary goes and what is replaced

    def __post_init__(self):
        if self.real is None:
            self.real = Path(os.path.realpath(self.final))


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

    def __init__(self, command: str = "", inputs=()):
        self.command = command
        self._targets: list[_Target] = []
        self._closed = False
        self.inputs: list[tuple[str, Path]] = []
        self.set_inputs(inputs)
        self._reads = _Reads.start()

    def set_inputs(self, inputs) -> None:
        """The command's input paths, ``(option, path)`` pairs (or bare paths): an output that is one of them, or a
        folder holding one, is refused when declared (writing it would destroy the input)."""
        self.inputs = []
        for item in inputs:
            option, path = item if isinstance(item, tuple) else ("", item)
            if path is not None and str(path) != "" and os.path.lexists(path):
                self.inputs.append((option, Path(os.path.realpath(path))))

    def _check_inputs(self, option: str, final: Path, real: Path, *, stale: tuple[str, ...] = ()) -> None:
        """Refuse an output that is an input, or a folder whose commit would replace or remove an input (a file an
        earlier run recorded in the folder's manifest: ``identify --data r/timeseries.csv --out r``). An input that
        merely lies in the output folder (a plant file beside its results) is left alone and allowed."""
        touched = None
        for input_option, path in self.inputs:
            if input_option and option_key(input_option) == option_key(option):
                continue  # the output option's own earlier value (an output is not its own input)
            named = f"the input {input_option} {str(path)!r}" if input_option else f"the input {str(path)!r}"
            if path == real:
                raise InputError(f"{_describe(option, final)} is {named}: writing it would destroy the input; "
                                 "choose another output")
            if real in path.parents:
                if touched is None:
                    touched = set(_manifest(real)) | set(stale)
                rel = path.relative_to(real).as_posix()
                if any(name == rel or name.startswith(rel + "/") for name in touched):
                    raise InputError(f"{_describe(option, final)} holds {named}, which an earlier run wrote there "
                                     "and this run would replace or remove; choose another output folder")

    @staticmethod
    def _check_text(option: str, path) -> None:
        text = os.fspath(path)
        if text.strip() == "":
            raise InputError(f"{option or 'the output'} is empty ({text!r}); give a path")

    # -- declarations ------------------------------------------------------------------------------------------
    def file(self, option: str, path) -> Path | None:
        """Declare an output file; returns the temporary path to write to (None when ``path`` is None)."""
        if path is None:
            return None
        self._check_text(option, path)
        text = os.fspath(path)
        if text.endswith(("/", os.sep)) and not Path(text).is_dir():
            raise InputError(f"{option} {text!r} ends with {os.sep!r}, which names a folder; give a "
                             "file name")
        final = Path(path)
        self._check_new(option, final)
        if final.is_dir():
            raise InputError(f"{_describe(option, final)} is a folder; give a file name")
        real = Path(os.path.realpath(final))
        self._check_inputs(option, final, real)
        try:
            mode = os.stat(final).st_mode
        except OSError:
            mode = None
        if mode is not None and not stat.S_ISREG(mode):
            # a device (/dev/null), FIFO, socket or /dev/stdout: written in place; renaming a temporary onto it
            # would replace the node with a regular file
            if not os.access(final, os.W_OK):
                raise InputError(f"{_describe(option, final)} exists and is not writable")
            self._targets.append(_Target(option, final, final, "direct", None, real=final))
            return final
        parent = real.parent
        if not parent.exists():
            raise InputError(f"{_describe(option, final)}: the folder {str(parent)!r} does not exist")
        if not parent.is_dir():
            raise InputError(f"{_describe(option, final)}: {str(parent)!r} is not a folder")
        _writable_folder(option, parent, final)
        if final.exists() and not os.access(final, os.W_OK):
            raise InputError(f"{_describe(option, final)} exists and is read-only")
        lock = self._lock(option, final, real)
        _remove_stale(parent, _file_temporaries(real))
        try:
            # the suffix stays last: writers that choose the format by it (matplotlib's savefig) see the real one
            fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{real.stem}{TMP_TAG}",
                                       suffix=real.suffix)
        except OSError as exc:
            lock.release()
            raise InputError(f"{_describe(option, final)}: cannot write in {str(parent)!r}: {exc.strerror}") from None
        os.close(fd)
        try:  # mkstemp makes 0600: give the file the mode the user's umask (or the file it replaces) asks for
            previous = os.stat(real).st_mode & 0o7777 if real.exists() else None
            os.chmod(tmp, previous if previous is not None else 0o666 & ~_umask())
        except OSError:
            pass
        self._targets.append(_Target(option, final, Path(tmp), "file", lock, real=real))
        return Path(tmp)

    def folder(self, option: str, path, *, stale: tuple[str, ...] = ()) -> Path:
        """Declare an output folder (created with its parents when missing); returns the temporary folder to write
        into. ``stale``: relative names this command may write; an earlier run's copy is removed when this run does
        not write it (for folders written before manifests existed)."""
        if path is None:
            raise InputError(f"{option or 'the output folder'} is missing; give a folder")
        self._check_text(option, path)
        given = Path(path)
        self._check_new(option, given)
        if given.exists() and not given.is_dir():
            raise InputError(f"{_describe(option, given)} exists and is not a folder")
        self._check_inputs(option, given, Path(os.path.realpath(given)), stale=tuple(stale))
        shown, final = given, Path(os.path.realpath(given))
        if final.parent == final:
            raise InputError(f"{_describe(option, shown)} is the root of the file system; give a folder of its own")
        existing = final.parent  # the temporary folder and the lock live beside the target
        while not existing.exists():
            if existing.parent == existing:  # pragma: no cover - the root always exists
                break
            existing = existing.parent
        if not existing.is_dir():
            raise InputError(f"{_describe(option, shown)}: {str(existing)!r} is a file, not a folder")
        _writable_folder(option, existing, shown)
        if final.is_dir():
            _writable_folder(option, final, shown)
        created = []
        for parent in reversed(final.parents):
            if not parent.exists():
                try:
                    parent.mkdir()
                except OSError as exc:
                    raise InputError(f"{_describe(option, shown)}: cannot create {str(parent)!r}: "
                                     f"{exc.strerror}") from None
                created.append(parent)
        try:
            lock = self._lock(option, shown, final)
            _remove_stale(final.parent, _folder_temporaries(final))
            try:
                tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=f".{final.name}{TMP_TAG}"))
                os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700: the folder gets what the umask asks for
            except OSError as exc:
                lock.release()
                raise InputError(f"{_describe(option, shown)}: cannot write in {str(final.parent)!r}: "
                                 f"{exc.strerror}") from None
        except InputError:
            for folder in reversed(created):
                try:
                    folder.rmdir()
                except OSError:
                    break
            raise
        self._targets.append(_Target(option, shown, tmp, "folder", lock, tuple(stale), created, real=final))
        return tmp

    def _check_new(self, option: str, final: Path) -> None:
        if self._closed:
            raise RuntimeError("this OutputSet was already committed or discarded")
        for t in self._targets:
            if _same(t.final, final) or _same(t.real, final):
                raise InputError(f"{_describe(option, final)} is also given as {t.option}; give distinct outputs")
            if _inside(final, t.real) or _inside(t.real, final):
                raise InputError(f"{_describe(option, final)} and {_describe(t.option, t.final)} overlap; give "
                                 "outputs outside each other")

    def _lock(self, option: str, final: Path, real: Path | None = None) -> _Lock:
        real = final if real is None else real
        lock = _Lock(real.parent / f".{real.name}{LOCK_TAG}")
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
        _Reads.stop(self._reads)
        try:
            self._check_reads()
        except InputError:
            self.discard()
            raise
        done = []
        try:
            for t in self._targets:
                if t.kind == "file":
                    os.replace(t.temporary, t.real)
                elif t.kind == "folder":
                    _commit_folder(t)
                done.append(t.final)
        finally:
            self._close(remove_temporaries=True)
        return done

    def check_reads(self) -> None:
        """Refuse now an output that is a file this command has read so far (a command calls it once it has read
        its inputs, before its long work: ``train CHART --out CHART/flow.csv`` stops before training); the commit
        checks again at the end."""
        self._check_reads()

    def _check_reads(self) -> None:
        """Refuse to put in place an output that would replace or remove a file this command read (found at the
        end: which files a command reads inside a chart folder is known only once it has read them)."""
        reads = {Path(p) for p in self._reads}
        for t in self._targets:
            if t.kind == "direct":
                continue
            hit = t.real if t.real in reads else None
            if hit is None and t.kind == "folder":
                written = set(_relative_files(t.temporary))
                touched = written | set(_manifest(t.real)) | set(t.stale)
                hit = next((p for p in reads if t.real in p.parents
                            and p.relative_to(t.real).as_posix() in touched), None)
            if hit is not None:
                verb = "is" if hit == t.real else "would replace or remove"
                raise InputError(f"{_describe(t.option, t.final)} {verb} the input {str(hit)!r} this command read; "
                                 "choose another output (nothing was written)")

    def discard(self) -> None:
        """Remove every temporary file and folder (and folders created for the outputs); release the locks."""
        _Reads.stop(self._reads)
        if not self._closed:
            self._close(remove_temporaries=True, remove_created=True)

    def _close(self, *, remove_temporaries: bool, remove_created: bool = False) -> None:
        self._closed = True
        _Reads.stop(self._reads)
        for t in reversed(self._targets):
            if t.kind == "direct":
                continue
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


#: File types matplotlib writes (``savefig`` chooses the format by the suffix).
PICTURE_SUFFIXES = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp",
                    ".gif", ".pgf", ".raw", ".rgba", ".avif")


def check_picture_suffix(option: str, path) -> None:
    """A picture output must end in a suffix matplotlib writes (checked before any work)."""
    if path is None:
        return
    suffix = Path(os.fspath(path)).suffix.lower()
    if suffix not in PICTURE_SUFFIXES:
        raise InputError(f"{option} {os.fspath(path)!r}: a picture needs one of the suffixes "
                         f"{', '.join(PICTURE_SUFFIXES[:4])}, ... ({', '.join(PICTURE_SUFFIXES)}), got "
                         f"{suffix or 'none'!r}")


def option_key(option: str) -> str:
    """``--out-dir``, ``OUT_DIR`` and ``out_dir`` -> ``out_dir`` (how an output option is matched to its argument)."""
    return option.lstrip("-").lower().replace("-", "_")


def _same(a: Path, b: Path) -> bool:
    return os.path.realpath(a) == os.path.realpath(b)


def _inside(inner: Path, outer: Path) -> bool:
    inner_abs, outer_abs = Path(os.path.realpath(inner)), Path(os.path.realpath(outer))
    return inner_abs != outer_abs and outer_abs in inner_abs.parents


def _file_temporaries(real: Path) -> re.Pattern:
    return re.compile(re.escape(f".{real.stem}{TMP_TAG}") + r"[A-Za-z0-9_]{8}" + re.escape(real.suffix) + "$")


def _folder_temporaries(real: Path) -> re.Pattern:
    return re.compile(re.escape(f".{real.name}{TMP_TAG}") + r"[A-Za-z0-9_]{8}$")


def _remove_stale(folder: Path, pattern: re.Pattern) -> None:
    """Remove the temporaries an earlier run left for this output (killed by SIGKILL or a power cut): called with
    the output's lock held, so no live hillsim process is writing them."""
    try:
        names = [n for n in os.listdir(folder) if pattern.match(n)]
    except OSError:
        return
    for name in names:
        path = folder / name
        try:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path, ignore_errors=True)
            else:
                path.unlink(missing_ok=True)
        except OSError:
            pass


def _manifest(folder: Path) -> list[str]:
    """The files an earlier run recorded in ``folder``'s manifest (empty when there is none or it is unreadable)."""
    try:
        names = json.loads((folder / MANIFEST).read_text(encoding="utf-8")).get("files", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [n for n in names if isinstance(n, str)] if isinstance(names, list) else []


def _relative_files(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink())


def _commit_folder(t: _Target) -> None:
    written = [name for name in _relative_files(t.temporary) if name != MANIFEST]
    (t.temporary / MANIFEST).write_text(json.dumps({"files": written}, indent=1) + "\n", encoding="utf-8")
    try:
        os.replace(t.temporary, t.real)  # new or empty folder: one atomic rename
        return
    except OSError:
        pass  # the folder holds files: replace them one by one
    previous = []
    try:
        previous = json.loads((t.real / MANIFEST).read_text(encoding="utf-8")).get("files", [])
    except (OSError, ValueError, AttributeError):
        previous = []
    for name in written:
        dest = t.real / name
        dest.parent.mkdir(parents=True, exist_ok=True)
        if dest.is_dir() and not dest.is_symlink():
            shutil.rmtree(dest)
        os.replace(t.temporary / name, dest)
    new = set(written)
    for name in set(previous) | set(t.stale):
        if not isinstance(name, str) or name in new or Path(name).is_absolute() or ".." in Path(name).parts:
            continue
        (t.real / name).unlink(missing_ok=True)
    os.replace(t.temporary / MANIFEST, t.real / MANIFEST)  # last: the manifest marks the set complete
