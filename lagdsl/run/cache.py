"""The build cache: generated artifacts (compiled libraries, NumPy modules) built once, verified on every use.

An entry is a file named for the content hash (`key`) of everything it was built from. Beside it,
a manifest `<entry>.manifest` records the key and the SHA-256 of the entry's bytes; it is written
after the entry is complete, so an entry without a valid manifest is unfinished or damaged.
Before an entry is used, its bytes are hashed and compared with the manifest, and the manifest's
key with the key asked for: a truncated file, a file copied in under another model's name, or a
stale manifest all lead to a rebuild instead of a crash or silently wrong results.

Builds happen in a private directory inside the cache (unique per process and thread) and are
renamed into place, so concurrent builders never see or overwrite half a file. The cache is
$LAGDSL_CACHE, or ~/.cache/lagdsl, created private (0700). Since an entry's key is computed from
public inputs, anyone who can write to the cache could plant a library whose constructor runs
inside lagc: a cache directory that is writable by others or owned by another user is not used,
nor an entry or manifest that is. When the cache cannot be created, written or trusted, a private
temporary cache is used for the rest of the process (removed at exit) and one warning goes to stderr;
`private_cache()` (`lagc run --no-cache`) does the same on purpose, without the warning.
`find_entry` only looks an entry up (a warm `lagc run`, `plans.py`; a warm `lagc check`,
`answers.py`); `clear` and `usage` serve `lagc cache clear` and `lagc cache info`. Beside the
entries, the front end and the code generator keep their helpers in subdirectories (`helper_directory`, HELPERS), which
`clear` removes too.
"""
from __future__ import annotations

import atexit
import contextlib
import errno
import hashlib
import json
import os
import re
import shutil
import stat
import sys
import tempfile
import time
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterator

from .. import __version__
from ..escape import visible

MANIFEST_SUFFIX = ".manifest"
# What the cache holds: entries named `<stem>-<20 hex digits of the key>.so|.py|.json|.pickle` (or
# `_` before the key) and their manifests; private build directories `.build-*`.
ENTRY_NAME = re.compile(r"[-_][0-9a-f]{20}\.(so|py|json|pickle)(\.manifest)?$")
BUILD_PREFIX = ".build-"
STALE_BUILD_SECONDS = 3600      # a build directory this old was left by a process that died
MAX_NAME = 200                  # bytes of an entry's name: room for the manifest's suffix and the build's
_fallbacks: dict[str, Path] = {}     # unusable cache root -> the private cache standing in for it
PRIVATE = "private"                  # the _fallbacks key of private_cache()
HELPERS = ("lark", "pint", "jinja2")     # the helper subdirectories: the parser's tables, pint's definitions,
                                         # the templates' compiled code
PACKAGE_FILES = (".py", ".lark", ".j2", ".c", ".h")    # what lagdsl generates code, plans and answers from


def cache_root() -> str:
    """Where the cache lives: $LAGDSL_CACHE, or ~/.cache/lagdsl."""
    return os.environ.get("LAGDSL_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "lagdsl")


@contextlib.contextmanager
def private_cache() -> Iterator[None]:
    """Inside the block, build in a private temporary cache (removed after it) and use nothing
    from the shared one."""
    with tempfile.TemporaryDirectory(prefix="lagdsl-cache-") as path:
        _fallbacks[PRIVATE] = Path(path)
        try:
            yield
        finally:
            del _fallbacks[PRIVATE]


def cache_directory() -> Path:
    """The cache directory, created if needed; a private temporary one if it cannot be written or trusted."""
    root = cache_root()
    if PRIVATE in _fallbacks or root in _fallbacks:
        return _fallbacks.get(PRIVATE) or _fallbacks[root]
    try:
        path = Path(root)
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        _check_trusted(path)
        # Try to create a file rather than trust the mode bits: as root, a 0o500 directory is
        # writable, and a read-only file system or a full quota only shows when one writes.
        with tempfile.TemporaryFile(dir=path):
            pass
        return path
    except OSError as error:
        return _fall_back(root, error)


def helper_directory(name: str) -> Path | None:
    """A subdirectory of the cache for what the front end and the code generator keep between
    processes (the parser's tables, pint's definitions, the templates' compiled code), created if needed; None, silently, where the cache cannot be
    used or trusted: those are only slower to rebuild, and a command that builds nothing should
    not warn about the build cache."""
    root = quiet_root()
    if root is None:
        return None
    try:
        path = root / name
        path.mkdir(mode=0o700, exist_ok=True)
        _check_trusted(path)
        return path
    except OSError:
        return None


def quiet_root() -> Path | None:
    """The cache directory (or the stand-in chosen before), created if needed; None, silently,
    where it cannot be used or trusted: for what only saves time (helpers, kept sources,
    codegen/kept.py) in a command that may build nothing, and so must not warn about the cache."""
    root = _fallbacks.get(PRIVATE) or _fallbacks.get(cache_root()) or Path(cache_root())
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
        _check_trusted(root)
        return root
    except OSError:
        return None


@lru_cache(maxsize=1)
def package_digest() -> str:
    """The version of lagdsl and the size and modification time of each of its files, for the
    keys of what is kept from its output (plans.py, answers.py): a changed code generator or
    integrator (even under the same version number, as while lagdsl is being developed) never
    runs a plan or program built before. (Hashing the files' bytes instead would add a tenth to
    a warm run.)"""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(__version__.encode())
    for path in sorted(package.rglob("*")):
        if path.suffix in PACKAGE_FILES and "__pycache__" not in path.parts:
            status = path.stat()
            digest.update(f"{path.relative_to(package).as_posix()}\0{status.st_size}\0{status.st_mtime_ns}\0".encode())
    return digest.hexdigest()


def _fall_back(root: str, error: OSError) -> Path:
    """A private temporary cache standing in for `root` from now on, with one warning."""
    _fallbacks[root] = _private_cache()
    print(f"lagc: warning: cannot use the build cache '{visible(root)}' ({error.strerror or error}); "
          f"using a temporary cache for this run", file=sys.stderr)
    return _fallbacks[root]


def _check_trusted(path: Path) -> None:
    """Raise PermissionError if another user could have put files at `path` (or in it, for a
    directory): it is owned by another user, or writable by group or others."""
    status = path.stat()
    if status.st_uid != os.getuid():
        raise PermissionError(errno.EPERM, f"it is owned by another user (uid {status.st_uid})")
    if status.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise PermissionError(errno.EPERM, f"it is writable by others (mode {stat.S_IMODE(status.st_mode):o})")


def _trusted_root() -> Path | None:
    """The directory to look entries up in without creating anything: the stand-in cache, or the
    cache if it exists and can be trusted (if it cannot, a stand-in from now on), else None."""
    root = cache_root()
    if PRIVATE in _fallbacks or root in _fallbacks:
        return _fallbacks.get(PRIVATE) or _fallbacks[root]
    path = Path(root)
    if not path.is_dir():
        return None
    try:
        _check_trusted(path)
    except OSError as error:
        return _fall_back(root, error)
    return path


def _private_cache() -> Path:
    path = tempfile.mkdtemp(prefix="lagdsl-cache-")
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return Path(path)


def cached_entry(name: str, key: str, build: Callable[[Path], None]) -> Path:
    """The verified cache entry `name` built from `key`; `build(path)` writes it when it is missing or damaged.

    `key` is the full content hash of the inputs (source, compiler, flags); `name` should carry a
    prefix of it, so that different inputs never share an entry.
    """
    directory = cache_directory()
    name = bounded_name(name)
    entry = directory / name
    if _is_valid(entry, key):
        return entry
    with tempfile.TemporaryDirectory(dir=directory, prefix=BUILD_PREFIX) as work:
        built = Path(work) / name
        build(built)
        manifest = Path(work) / (name + MANIFEST_SUFFIX)
        manifest.write_text(json.dumps({"key": key, "sha256": _digest(built)}) + "\n", encoding="utf-8")
        os.replace(built, entry)
        os.replace(manifest, _manifest_path(entry))     # last: the manifest vouches for a complete entry
    return entry


def find_entry(name: str, key: str) -> Path | None:
    """The verified entry `name` built from `key` if the cache holds one (nothing is created)."""
    directory = _trusted_root()
    entry = directory / bounded_name(name) if directory is not None else None
    return entry if entry is not None and _is_valid(entry, key) else None


def discard(entry: Path) -> None:
    """Remove an entry that proved unusable (its manifest first), so that it is built again."""
    _manifest_path(entry).unlink(missing_ok=True)
    entry.unlink(missing_ok=True)


def bounded_name(name: str) -> str:
    """`name` with a long stem (a model or scene name of hundreds of characters) shortened to a
    prefix and a hash of the whole, so that every file name made from it stays within the file
    system's limit of 255 bytes; the key's digits and the suffix are kept."""
    if len(name.encode()) <= MAX_NAME:
        return name
    tail = ENTRY_NAME.search(name)
    cut = tail.start() if tail else len(name)
    stem = name[:cut]
    return stem[:40] + "~" + hashlib.sha256(stem.encode()).hexdigest()[:16] + name[cut:]


def _is_valid(entry: Path, key: str) -> bool:
    """The entry exists, both it and its manifest are regular files only this user could have
    written, the manifest was written for `key`, and the entry's bytes are the ones recorded."""
    try:
        for path in (entry, _manifest_path(entry)):
            if not stat.S_ISREG(path.lstat().st_mode):
                return False
            _check_trusted(path)
        record = json.loads(_manifest_path(entry).read_text(encoding="utf-8"))
        return (isinstance(record, dict) and record.get("key") == key
                and record.get("sha256") == _digest(entry))
    except (OSError, ValueError):     # missing or unreadable; ValueError covers bad JSON and UTF-8
        return False


def _manifest_path(entry: Path) -> Path:
    return entry.with_name(entry.name + MANIFEST_SUFFIX)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def usage() -> tuple[int, int]:
    """(number of entries, their bytes with the manifests') in the cache; nothing is created."""
    files = _entry_files(Path(cache_root()))
    return sum(1 for f in files if not f.name.endswith(MANIFEST_SUFFIX)), sum(f.stat().st_size for f in files)


def clear() -> int:
    """Remove every entry, manifest, helper subdirectory and stale build directory; other files
    are left alone. Returns the number of entries removed."""
    directory = Path(cache_root())
    files = _entry_files(directory)
    for file in files:
        file.unlink(missing_ok=True)
    if directory.is_dir():
        for build in directory.glob(BUILD_PREFIX + "*"):
            _remove_directory(build, stale=time.time() - build.lstat().st_mtime > STALE_BUILD_SECONDS)
        for name in HELPERS:
            if os.path.lexists(directory / name):
                _remove_directory(directory / name, stale=True)
    return sum(1 for f in files if not f.name.endswith(MANIFEST_SUFFIX))


def _remove_directory(path: Path, stale: bool) -> None:
    """Remove a directory of ours if `stale`; a link in its place is never ours: remove the link,
    not its target."""
    if stat.S_ISLNK(path.lstat().st_mode):
        path.unlink(missing_ok=True)
    elif stale:
        shutil.rmtree(path, ignore_errors=True)


def _entry_files(directory: Path) -> list[Path]:
    if not directory.is_dir():
        return []
    return sorted(f for f in directory.iterdir() if ENTRY_NAME.search(f.name) and f.is_file())
