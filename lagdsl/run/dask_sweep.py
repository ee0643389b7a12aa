"""Sweeps on a Dask cluster: chunks of members run by lag_run_batch on the workers.

The compiled library travels as the result of a task that holds its bytes, not as scattered
data: the scheduler can compute it again when the workers that held it die, so a chunk whose
worker died runs again elsewhere. Finished chunks are kept; a chunk that failed (its worker died
more often than Dask allows) is submitted again, up to RESUBMISSIONS times, so every member
arrives exactly once, in member order.
"""
from __future__ import annotations

import ctypes
import hashlib
import math
import os
import time as clock
from collections.abc import Callable

import numpy as np

from ..codegen import GeneratedSource
from ..errors import LagError
from .cache import cached_entry
from .loading import load, load_program_library
from .sweep import BatchLayout, run_c_batch

CHUNKS_PER_THREAD = 4        # chunks per worker thread, so that a lost worker costs little
RESUBMISSIONS = 3            # times a chunk that failed on the cluster is submitted again
_worker_libraries: dict[str, ctypes.CDLL] = {}


def run_chunk(library: bytes, source: str, stem: str, layout: BatchLayout, parameters: np.ndarray,
              initial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A chunk of members on a Dask worker: the shipped library (kept in the worker's build cache
    under the hash of its bytes), or, when this machine cannot load it, one built here from the
    source. One thread per chunk: Dask runs the chunks in parallel."""
    return run_c_batch(_worker_library(library, source, stem), layout, parameters, initial, 1)


def _worker_library(library: bytes, source: str, stem: str) -> ctypes.CDLL:
    key = hashlib.sha256(library).hexdigest()
    if key not in _worker_libraries:
        path = cached_entry(f"{stem}-shipped-{key[:20]}.so", key, lambda entry: entry.write_bytes(library))
        try:
            shipped = load_program_library(path)
        except LagError:        # another architecture or C library: build it here
            shipped = None
        _worker_libraries[key] = shipped or load(GeneratedSource("c", source, stem))
    return _worker_libraries[key]


def _the_library(library: bytes) -> bytes:
    """The task whose result is the library: its bytes stay in the task, which can run again."""
    return library


def run_dask(client, library: bytes, source: str, stem: str, layout: BatchLayout, parameters: np.ndarray,
             initial: np.ndarray, on_progress: Callable[[int], None] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Send chunks of members to the cluster behind `client`; results come back in member order.

    Returns the values, the summaries and the number of chunks.
    """
    threads = max(1, sum(client.nthreads().values()))
    count = len(initial)
    size = max(1, math.ceil(count / (CHUNKS_PER_THREAD * threads)))
    bounds = [(lo, min(lo + size, count)) for lo in range(0, count, size)]
    tag = f"lagdsl-sweep-{stem}-{os.getpid()}-{clock.time_ns()}"
    shipped = client.submit(_the_library, library, pure=False, key=f"{tag}-library")

    def submit(chunk: int, attempt: int):
        lo, hi = bounds[chunk]
        return client.submit(run_chunk, shipped, source, stem, layout, parameters[lo:hi], initial[lo:hi],
                             retries=3, pure=False, key=f"{tag}-{lo}-{attempt}")

    parts = _gather_chunks(client, submit, len(bounds), lambda chunk: bounds[chunk][1] - bounds[chunk][0],
                           on_progress)
    values = np.concatenate([parts[chunk][0] for chunk in range(len(bounds))])
    summaries = np.concatenate([parts[chunk][1] for chunk in range(len(bounds))])
    return values, summaries, len(bounds)


def _gather_chunks(client, submit: Callable, chunks: int, members: Callable[[int], int],
                   on_progress: Callable[[int], None] | None) -> dict[int, tuple]:
    """The result of every chunk: each collected as it completes (and released), a chunk that
    failed submitted again, at most RESUBMISSIONS times."""
    from dask.distributed import as_completed
    chunk_of = {}
    for chunk in range(chunks):
        chunk_of[submit(chunk, 0)] = (chunk, 0)
    parts, finished = {}, 0
    pending = as_completed(list(chunk_of))
    for future in pending:
        chunk, attempt = chunk_of.pop(future)
        if future.status == "finished":
            parts[chunk] = future.result()
            finished += members(chunk)
            if on_progress is not None:
                on_progress(finished)
        elif attempt < RESUBMISSIONS:
            again = submit(chunk, attempt + 1)
            chunk_of[again] = (chunk, attempt + 1)
            pending.add(again)
        else:
            future.result()         # raises the chunk's error
        future.release()
    return parts
