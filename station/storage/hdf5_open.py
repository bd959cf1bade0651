"""Opening a run file for reading without hanging on a damaged one, and saying why it fails.

Two HDF5 behaviours make a reader of a damaged file hang or lie when it opens it in SWMR
mode (as a live reader of a file being written must):

* A SWMR reader may catch a metadata block while the writer rewrites it, so the library
  retries every metadata read whose checksum fails, 100 times, sleeping 1 ns, 2 ns,
  4 ns, ... between tries: on a truncated or bit-flipped file each bad block costs about
  2^100 ns, which is forever (a run file cut to its first 3 kB hung ``station analyze``
  for minutes).
* A SWMR reader skips the library's check that the file is as long as its superblock
  says (the writer may still be extending it), and the library returns zeros for raw
  data read past the end of the file: a run file cut in half read as real samples
  followed by zeros.

So :func:`open_h5` reads the superblock first (:func:`superblock`). A file that no
writer holds open (its consistency flags clear) is opened without SWMR: the length check
and every checksum fail at once. A file a recorder holds (live, or killed) is opened in
SWMR mode with the retries cut to :data:`SWMR_READ_ATTEMPTS` (a torn read during a
write resolves in microseconds; the retries then sleep about 17 ms in all); if it is
shorter than its superblock says, every chunk read is first checked to lie inside it
(:func:`cut_short`, :func:`chunks_within`): a chunk of zeros passes HDF5's Fletcher-32
check. Raw data carry the writer's Fletcher-32 chunk checksums (a flipped bit fails the
read). Every HDF5
failure, at open or later while reading (:func:`reading`), becomes one
:class:`~station.errors.RecordFormatError` line that names the file and what to do.
"""

from __future__ import annotations

import ctypes
import glob
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import h5py
from h5py._objects import phil

from station.errors import RecordFormatError, StationError

SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Metadata read attempts of a SWMR reader (HDF5's default is 100: hours on a bad block).
SWMR_READ_ATTEMPTS = 24


@dataclass(frozen=True)
class Superblock:
    """What the first 48 bytes of an HDF5 file (superblock version 2 or 3) say.

    Attributes
    ----------
    version : int
        Superblock version (0..3; the fields below are read for 2 and 3 only).
    open_for_write : bool
        A writer has it open, or died with it open (the file-consistency flags).
    stored_eof : int
        End-of-file address the writer recorded at its last flush, bytes (-1 if unknown).
    size : int
        The file's length now, bytes.
    """

    version: int
    open_for_write: bool
    stored_eof: int
    size: int

    @property
    def truncated(self) -> bool:
        """Shorter than its superblock says (only conclusive for a closed file)."""
        return 0 <= self.size < self.stored_eof


def superblock(path: Path) -> Superblock:
    """The superblock of ``path`` (a file that is not HDF5 raises RecordFormatError).

    Raises
    ------
    RecordFormatError
        A directory, an empty file, or no HDF5 signature at its start.
    """
    if path.is_dir():
        raise RecordFormatError(f"{path} is a directory, not a run file: give the .h5 file "
                                f"inside it")
    with open(path, "rb") as fh:
        head = fh.read(48)
        size = os.fstat(fh.fileno()).st_size
    if head[:8] != SIGNATURE:
        raise RecordFormatError(f"{path}: not an HDF5 file (no HDF5 signature at its start"
                                f"{'; the file is empty' if not head else ''})")
    version = head[8] if len(head) > 8 else -1
    if version in (2, 3) and len(head) >= 48 and head[9] == 8:
        return Superblock(version, head[11] != 0, int.from_bytes(head[28:36], "little"), size)
    return Superblock(version, False, -1, size)


@cache
def _set_read_attempts() -> ctypes._CFuncPtr | None:  # type: ignore[name-defined]
    """``H5Pset_metadata_read_attempts`` of the HDF5 library h5py loaded (h5py does not
    wrap it), or None where it cannot be found."""
    candidates = []
    try:
        with open("/proc/self/maps", encoding="ascii", errors="replace") as fh:
            candidates += sorted({line.split()[-1] for line in fh
                                  if "libhdf5" in line and "hdf5_hl" not in line})
    except OSError:
        pass
    base = os.path.dirname(h5py.__file__)
    for pattern in ("../h5py.libs/libhdf5-*.so*", ".dylibs/libhdf5*.dylib", "hdf5.dll"):
        candidates += [p for p in sorted(glob.glob(os.path.join(base, pattern)))
                       if "hdf5_hl" not in p]
    for name in candidates:
        try:
            fn = ctypes.CDLL(name).H5Pset_metadata_read_attempts
        except (OSError, AttributeError):
            continue
        fn.argtypes = [ctypes.c_int64, ctypes.c_uint]
        fn.restype = ctypes.c_int
        return fn
    return None


def swmr_reader(path: Path, *, read_attempts: int = SWMR_READ_ATTEMPTS) -> h5py.File:
    """``path`` opened as a SWMR reader with few metadata retries (``read_attempts``; a
    salvage, which no writer races, takes 1): it opens a file its writer still holds, and
    a truncated one (for salvage: reads past the end return zeros, which only checksums
    or :func:`chunks_within` tell from data)."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    setter = _set_read_attempts()
    if setter is not None:
        setter(fapl.id, read_attempts)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ,
                        fapl=fapl)
    return h5py.File(fid)


def damaged(path: Path, exc: BaseException) -> RecordFormatError:
    """The one-line error of a run file HDF5 cannot read (``exc``: what HDF5 said)."""
    reason = " ".join(str(exc).split())[:200] or type(exc).__name__
    return RecordFormatError(f"{path}: damaged run file, cannot be read ({reason}); "
                             f"`station recover {path}` salvages what is readable")


def open_h5(path: Path) -> h5py.File:
    """``path`` opened read-only: without SWMR when no writer holds it, else as a SWMR
    reader with few retries (see the module docstring).

    Raises
    ------
    RecordFormatError
        Not HDF5, truncated, or damaged (one line: the file, why, what to do).
    """
    sb = superblock(path)
    if not sb.open_for_write and sb.truncated:
        raise RecordFormatError(
            f"{path}: truncated run file ({sb.size} of its {sb.stored_eof} bytes): "
            f"`station recover {path}` salvages what is readable")
    try:
        return swmr_reader(path) if sb.open_for_write else h5py.File(path, "r")
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        raise damaged(path, exc) from exc


@contextmanager
def reading(path: Path) -> Iterator[None]:
    """Turn an HDF5 failure inside the block (a checksum, a block past the end) into the
    one-line :func:`damaged` error; the station's own errors pass unchanged."""
    try:
        yield
    except StationError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise damaged(path, exc) from exc


def cut_short(path: Path) -> int | None:
    """The length of ``path`` when it is held open for writing (live, or left by a killed
    recorder) and shorter than its superblock says: its chunks must then be checked to
    lie inside it (:func:`chunks_within`). None otherwise (HDF5 checks a closed file's
    length itself, and a file at least that long holds every chunk committed)."""
    sb = superblock(path)
    return sb.size if sb.open_for_write and sb.truncated else None


def refresh_alone(ds: h5py.Dataset) -> h5py.Dataset:
    """``ds`` with its metadata read again, where that is both needed and safe; ``ds`` itself.

    Needed only when the file is open as a SWMR reader (its writer may have extended the
    dataset since it was opened); a file no writer holds is as it was opened. Safe only when
    ``ds`` is the one open handle on that dataset in this process: HDF5 (2.0.0, as h5py 3.16
    ships it) rebuilds a refreshed dataset's chunk layout only partly when another handle
    to it is open (another reader of the same file in this process: the TUI's live view
    beside a spec sheet), and every later read of it then fails with "can't insert
    duplicate key" or, in a file of the latest format, returns other rows without an error.
    With another handle open the dataset is left as it is: its extent is then the one seen
    when that handle refreshed it, a few flushes old at worst, never more than was written.
    """
    with phil:  # no other thread opens a handle between the count and the refresh
        if ds.file.swmr_mode and _handles_on(ds) == 1:
            ds.refresh()
    return ds


def _handles_on(ds: h5py.Dataset) -> int:
    """Open dataset handles in this process on the dataset ``ds`` is (``ds``'s included),
    through any open of its file."""
    path = h5py.h5f.get_name(ds.id)
    name = h5py.h5i.get_name(ds.id)
    return sum(1 for i in h5py.h5f.get_obj_ids(h5py.h5f.OBJ_ALL, h5py.h5f.OBJ_DATASET)
               if h5py.h5i.get_name(i) == name and h5py.h5f.get_name(i) == path)


def chunks_within(ds: h5py.Dataset, start: int, stop: int, size: int) -> bool:
    """Whether every chunk holding rows ``start:stop`` of a chunked dataset lies inside a
    file of ``size`` bytes (a chunk past the end reads as zeros without complaint)."""
    if ds.chunks is None:
        return True
    rows = ds.chunks[0]
    zero = (0,) * (len(ds.shape) - 1)
    for first in range(start - start % rows, stop, rows):
        info = ds.id.get_chunk_info_by_coord((first, *zero))
        if info.byte_offset is None or info.byte_offset + info.size > size:
            return False
    return True
