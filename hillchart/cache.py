"""Where compiled code is cached: a user cache folder, never the installed package or the source tree.

numba's ``cache=True`` writes its index and object files beside the module that defines the function by default:
into ``site-packages`` for an installed copy. Those files are not part of the installation, so ``pip`` leaves them
behind when it replaces the package, and a later editable install then finds a folder ``simulate/`` that holds only
caches and imports it as an empty namespace package (every ``hillsim`` call failed with ``No module named
'simulate.components.registry'``). :func:`configure_numba_cache` therefore points numba at a folder of the user's
cache (``$HILLSIM_CACHE_DIR/numba``, else ``$XDG_CACHE_HOME/hillsim/numba``, else ``~/.cache/hillsim/numba``; a
temporary folder when none is writable), in a subfolder keyed by this installation (version and location), before
numba is imported. A ``NUMBA_CACHE_DIR`` the user set is kept.

What numba finds there is checked by numba itself: an entry of another CPU, numba or Python version, or of an edited
source file, is a cache miss and is compiled anew. Numba checks a cached function against its own file only, though,
not against the files of the functions it calls and compiles into it: after an edit of
``simulate/components/turbine/suter_kernels.py`` the cached kernels of ``four_quadrant.py`` ran the old code. The
subfolder is therefore keyed by the content of every module that uses numba as well (:func:`kernel_stamp`), and
the folders of earlier contents at the same location are removed once a day has passed since they were last written.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

def cache_root() -> Path:
    """The folder under which hillsim caches compiled code (not created here)."""
    root = os.environ.get("HILLSIM_CACHE_DIR")
    if root:
        return Path(root)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "hillsim"


#: The packages whose modules compile with numba.
COMPILED_PACKAGES = ("hillchart", "simulate")
#: A cache folder of an earlier content at the same location is removed when it was last written this long ago (s).
STALE_AFTER_S = 86400.0


def kernel_stamp(root: Path | None = None) -> str:
    """8 hex digits of the names and contents of the modules of :data:`COMPILED_PACKAGES` under ``root`` (default:
    the installed location) that mention numba: any edit of compiled code changes it."""
    root = Path(__file__).resolve().parent.parent if root is None else Path(root)
    digest = hashlib.sha256()
    for package in COMPILED_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            text = path.read_bytes()
            if b"numba" in text:
                digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:8]


def installation_key(version: str) -> str:
    """``<version>-<8 hex digits of the installed package's location>-<kernel_stamp>``: two installations (a wheel
    in a venv and an editable checkout) never share a cache folder, nor two contents of one checkout."""
    location = str(Path(__file__).resolve().parent.parent)
    return f"{version}-{hashlib.sha256(location.encode()).hexdigest()[:8]}-{kernel_stamp()}"


def remove_stale(folder: Path, now: float | None = None) -> list[Path]:
    """Remove the cache folders beside ``folder`` of the same version and location and another content
    (:func:`installation_key`), or of the key without the content (written before it had one), last written more
    than :data:`STALE_AFTER_S` ago; return them. A folder being written by a running process of an older content is
    younger than that and kept."""
    import shutil
    import time

    now = time.time() if now is None else now
    prefix = folder.name.rsplit("-", 1)[0] + "-"
    removed = []
    legacy = folder.parent / prefix[:-1]  # the folder of this location before the key had the kernel stamp
    for other in [*folder.parent.glob(prefix + "*"), *([legacy] if legacy.is_dir() else [])]:
        if other == folder or not other.is_dir():
            continue
        try:
            if now - other.stat().st_mtime > STALE_AFTER_S:
                shutil.rmtree(other)
                removed.append(other)
        except OSError:  # another process removed it, or it is not ours to remove: it stays
            continue
    return removed


def first_writable(candidates) -> Path | None:
    """The first of ``candidates`` (paths) that can be created and written to (a probe file is written and removed),
    or None."""
    for path in candidates:
        try:
            path.mkdir(parents=True, exist_ok=True)
            probe = path / f".probe-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
            return path
        except OSError:
            continue
    return None


def temporary_cache(name: str) -> Path:
    """A per-user folder ``name`` in the temporary directory: the cache's fallback where no cache folder is
    writable."""
    return Path(tempfile.gettempdir()) / f"{name}-{os.getuid() if hasattr(os, 'getuid') else 0}"


def numba_cache_dir(version: str) -> Path:
    """The folder numba caches hillsim's compiled functions in: under :func:`cache_root`, else a temporary folder."""
    key = installation_key(version)
    path = first_writable([cache_root() / "numba" / key, temporary_cache("hillsim-numba") / key])
    if path is None:
        raise OSError("no writable folder for hillsim's compiled-code cache; set HILLSIM_CACHE_DIR to one")
    remove_stale(path)
    return path


def configure_numba_cache(version: str) -> str:
    """Point numba's disk cache at :func:`numba_cache_dir` (for the package ``version``) unless ``NUMBA_CACHE_DIR``
    is set; return the folder.

    Sets the environment variable (read when numba is imported, and inherited by worker processes) and, when numba
    is already imported, its configuration as well.
    """
    path = os.environ.get("NUMBA_CACHE_DIR")
    if not path:
        path = str(numba_cache_dir(version))
        os.environ["NUMBA_CACHE_DIR"] = path
    config = sys.modules.get("numba.core.config")
    if config is not None and not getattr(config, "CACHE_DIR", ""):
        config.CACHE_DIR = path
    return path
