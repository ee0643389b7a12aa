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
cache is used for the rest of the process (removed at exit) and one warning goes to stderr.
"""
from __future__ import annotations

import atexit
import hashlib
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable

MANIFEST_SUFFIX = ".manifest"
_fallbacks: dict[str, Path] = {}     # unusable cache root -> the private cache standing in for it


def cache_directory() -> Path:
    """The cache directory, created if needed; a private temporary one if it cannot be written."""
    root = os.environ.get("LAGDSL_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "lagdsl")
    if root in _fallbacks:
        return _fallbacks[root]
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
    with tempfile.TemporaryDirectory(dir=directory, prefix=".build-") as work:
        built = Path(work) / name
        build(built)
        manifest = Path(work) / (name + MANIFEST_SUFFIX)
        manifest.write_text(json.dumps({"key": key, "sha256": _digest(built)}) + "\n", encoding="utf-8")
        os.replace(built, entry)
        os.replace(manifest, _manifest_path(entry))     # last: the manifest vouches for a complete entry
    return entry


def is_cached(name: str, key: str) -> bool:
    """Whether cached_entry(name, key, ...) would find a valid entry without building."""
    return _is_valid(cache_directory() / name, key)


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
