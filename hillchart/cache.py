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
source file, is a cache miss and is compiled anew.
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


def installation_key(version: str) -> str:
    """``<version>-<8 hex digits of the installed package's location>``: two installations (a wheel in a venv and an
    editable checkout) never share a cache folder."""
    location = str(Path(__file__).resolve().parent.parent)
    return f"{version}-{hashlib.sha256(location.encode()).hexdigest()[:8]}"


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
