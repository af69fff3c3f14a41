"""Output locations, checked once before the work, and the files written into them counted.

:func:`output_folder` and :func:`output_file` check a location before any computation: a folder must be a
folder or not exist yet, and the nearest existing folder must be writable (probed by creating and deleting a
hidden file, which also catches read-only mounts and immutable folders that permission bits do not show); a file must not be a folder, a device or any
other non-regular file, must not lie under a file, and its folder must be writable. A problem is an
:class:`~spherestep.errors.InputError` naming the option (exit status 2 in the CLI).

:class:`Outputs` names the files a command writes; an ``OSError`` while writing becomes one line: a full disk
(``ENOSPC``, ``EDQUOT``, ``EFBIG``) a :class:`~spherestep.errors.ComputationError` (exit 1) that says
"N of M files written", anything else an InputError. Files are written atomically (:mod:`spherestep.atomic`),
so a failure never leaves a half-written file under its final name. A folder the set created is removed again when
it holds nothing at the end; an interrupted set (Ctrl-C, SIGTERM) removes the files it wrote, so the folder is
either complete or absent.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
import time
from pathlib import Path

from .atomic import remove_stale
from .errors import ComputationError, InputError
from .interrupts import interrupt_of, last_signal

DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def _why(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def _file_above(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` when it is not a folder (``path`` lies under a file)."""
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            return None if parent.is_dir() else parent
    return None


def _probe(folder: Path, name: str) -> None:
    """Create and delete a hidden file in ``folder``; InputError naming ``name`` if that fails."""
    try:
        fd, probe = tempfile.mkstemp(prefix=f".spherestep-probe.{os.getpid()}.", suffix=".tmp", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise ComputationError(f"{name} {str(folder)!r}: the disk is full ({_why(exc)}); 0 files written; "
                                   "free some space and run again") from None
        raise InputError(f"{name} {str(folder)!r} is not writable ({_why(exc)}); give a folder you can "
                         "write to") from None


def _nearest_existing(path: Path) -> Path:
    """``path`` itself if it exists, else its nearest existing ancestor."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(".")


def output_folder(path: str | os.PathLike, name: str = "--out") -> Path:
    """Check that ``path`` is, or can be created as, a writable folder (it is created by the first write, so a
    refused command leaves nothing behind) and remove stale temporary files in it; returns it as a Path.
    InputError naming ``name`` otherwise."""
    folder = Path(path)
    if str(path) == "":
        raise InputError(f"{name} is empty; give a folder such as spherestep-out")
    if folder.exists() and not folder.is_dir():
        kind = "a file" if folder.is_file() else "not a folder (a device or special file)"
        raise InputError(f"{name} {str(folder)!r} is {kind}; give a folder")
    above = _file_above(folder)
    if above is not None:
        raise InputError(f"{name} {str(folder)!r} lies under {str(above)!r}, which is a file; give a folder")
    _probe(_nearest_existing(folder), name)
    if folder.is_dir():
        remove_stale(folder)
    return folder


def output_file(path: str | os.PathLike, name: str = "--out", *, suffixes: tuple[str, ...] = (),
                force: bool | None = None) -> Path:
    """Check that a file can be written at ``path``: not a folder, device or other non-regular file, not under
    a file, in a writable (or creatable) folder, ending in one of ``suffixes`` when given. With
    ``force`` False an existing file is refused (give ``--force``); None overwrites. Returns it as a Path."""
    file = Path(path)
    if str(path) == "" or file.name in ("", ".", ".."):
        raise InputError(f"{name} {str(path)!r} is not a file name; give one such as out{suffixes[0] if suffixes else ''}")
    if file.is_dir():
        raise InputError(f"{name} {str(file)!r} is a folder; give a file name such as "
                         f"{str(file / ('out' + (suffixes[0] if suffixes else '')))!r}")
    if file.exists() or file.is_symlink():
        try:
            mode = os.stat(file).st_mode
        except OSError as exc:
            raise InputError(f"{name} {str(file)!r} cannot be used ({_why(exc)}); give another file name") from None
        if not stat.S_ISREG(mode):
            raise InputError(f"{name} {str(file)!r} is not a regular file (a device, pipe or socket); give a file "
                             "name")
        if force is False:
            raise InputError(f"{name} {str(file)!r} exists; give --force to overwrite it, or choose another name")
    if suffixes and file.suffix.lower() not in suffixes:
        raise InputError(f"{name} {str(file)!r} must end in {' or '.join(suffixes)}")
    above = _file_above(file)
    if above is not None:
        raise InputError(f"{name} {str(file)!r} lies under {str(above)!r}, which is a file; give a file in a folder")
    _probe(_nearest_existing(file.parent), name)
    if file.parent.is_dir():
        remove_stale(file.parent)
    return file


class Outputs:
    """The files a command writes into a folder: ``with Outputs(out, ["plan.csv", …]): …``. Inside the block
    an ``OSError`` becomes one line (module docstring) that counts the named files written since the block
    began (found on disk by their modification time, so files written by library functions count too)."""

    def __init__(self, where: str | os.PathLike, names, option: str = "--out"):
        self.where, self.names, self.option = Path(where), tuple(names), option
        self._start = 0
        self._created = False

    @property
    def paths(self) -> list[Path]:
        """Every file of the set, written or not."""
        return [self.where / n for n in self.names]

    def written(self) -> list[Path]:
        """The files of the set written since the block began."""
        done = []
        for path in self.paths:
            try:
                if os.stat(path).st_mtime_ns >= self._start:
                    done.append(path)
            except OSError:
                pass
        return done

    def __enter__(self) -> Outputs:
        if not self._start:  # the first block starts the set; later blocks add to it
            self._start = time.time_ns() - 10_000_000  # 10 ms: file-system clocks may lag time.time_ns
            self._created = not self.where.exists()
        return self

    def _remove_if_empty(self) -> None:
        """Remove the folder when this set created it and nothing is in it."""
        try:
            if self._created and self.where.is_dir() and not any(self.where.iterdir()):
                self.where.rmdir()
        except OSError:
            pass

    def __exit__(self, kind, exc, tb) -> bool:
        if interrupt_of(exc) is not None or (exc is not None and last_signal()):  # Ctrl-C or SIGTERM: complete or absent
            for path in self.written():
                try:
                    path.unlink()
                except OSError:
                    pass
            self._remove_if_empty()
            return False
        if not isinstance(exc, OSError):
            return False
        self._remove_if_empty()
        done = f"{len(self.written())} of {len(self.names)} files written to {self.where}"
        where = f" ({exc.filename})" if exc.filename else ""
        if exc.errno in DISK_FULL:
            raise ComputationError(f"the disk is full{where}: {done}; the set is incomplete, free some space and "
                                   "run again") from None
        raise InputError(f"{self.option}: could not write{where} ({_why(exc)}); {done}") from None
