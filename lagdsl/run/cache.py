"""The build cache: generated artifacts (compiled libraries, NumPy modules) built once, verified on every use.

An entry is a file named for the content hash (`key`) of everything it was built from. Beside it,
a manifest `<entry>.manifest` records the key and the SHA-256 of the entry's bytes; it is written
after the entry is complete, so an entry without a valid manifest is unfinished or damaged.
Before an entry is used, its bytes are hashed and compared with the manifest, and the manifest's
key with the key asked for: a truncated file, a file copied in under another model's name, or a
stale manifest all lead to a rebuild instead of a crash or silently wrong results.

Builds happen in a private directory inside the cache (unique per process and thread) and are
renamed into place, so concurrent builders never see or overwrite half a file. The cache is
$LAGDSL_CACHE, or ~/.cache/lagdsl; when it cannot be created or written, a private temporary
cache is used for the rest of the process (removed at exit) and one warning goes to stderr;
`private_cache()` (`lagc run --no-cache`) does the same on purpose, without the warning.
`find_entry` only looks an entry up (a warm `lagc run`, `plans.py`); `clear` and `usage` serve
`lagc cache clear` and `lagc cache info`.
"""
from __future__ import annotations

import atexit
import contextlib
import hashlib
import json
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterator

MANIFEST_SUFFIX = ".manifest"
# What the cache holds: entries named `<stem>-<20 hex digits of the key>.so|.py|.json` (or `_`
# before the key) and their manifests; private build directories `.build-*`.
ENTRY_NAME = re.compile(r"[-_][0-9a-f]{20}\.(so|py|json)(\.manifest)?$")
BUILD_PREFIX = ".build-"
STALE_BUILD_SECONDS = 3600      # a build directory this old was left by a process that died
_fallbacks: dict[str, Path] = {}     # unusable cache root -> the private cache standing in for it
PRIVATE = "private"                  # the _fallbacks key of private_cache()


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
    """The cache directory, created if needed; a private temporary one if it cannot be written."""
    root = cache_root()
    if PRIVATE in _fallbacks or root in _fallbacks:
        return _fallbacks.get(PRIVATE) or _fallbacks[root]
    try:
        path = Path(root)
        path.mkdir(parents=True, exist_ok=True)
        # Try to create a file rather than trust the mode bits: as root, a 0o500 directory is
        # writable, and a read-only file system or a full quota only shows when one writes.
        with tempfile.TemporaryFile(dir=path):
            pass
        return path
    except OSError as error:
        _fallbacks[root] = _private_cache()
        print(f"lagc: warning: cannot use the build cache '{root}' ({error.strerror or error}); "
              f"using a temporary cache for this run", file=sys.stderr)
        return _fallbacks[root]


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
    root = cache_root()
    entry = (_fallbacks.get(PRIVATE) or _fallbacks.get(root) or Path(root)) / name
    return entry if _is_valid(entry, key) else None


def _is_valid(entry: Path, key: str) -> bool:
    """The entry exists, its manifest was written for `key`, and its bytes are the ones recorded."""
    try:
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
    """Remove every entry, manifest and stale build directory; other files are left alone.
    Returns the number of entries removed."""
    directory = Path(cache_root())
    files = _entry_files(directory)
    for file in files:
        file.unlink(missing_ok=True)
    if directory.is_dir():
        for build in directory.glob(BUILD_PREFIX + "*"):
            if time.time() - build.stat().st_mtime > STALE_BUILD_SECONDS:
                shutil.rmtree(build, ignore_errors=True)
    return sum(1 for f in files if not f.name.endswith(MANIFEST_SUFFIX))


def _entry_files(directory: Path) -> list[Path]:
    if not directory.is_dir():
        return []
    return sorted(f for f in directory.iterdir() if ENTRY_NAME.search(f.name) and f.is_file())
