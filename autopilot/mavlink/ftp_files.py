"""The files the flight controller serves over MAVLink FTP: a read-only tree of named mounts.

``/`` lists one directory per mount; a mount is either a directory on disk (the flight logs,
``--log-dir``, served with its files and subdirectories as they are) or a few files held in memory
(the component metadata).  Paths may be absolute or relative to ``/`` (PX4's metadata URIs carry no
leading slash), with or without a trailing slash; ``.`` is ignored, ``..`` or a path that leaves its
mount (a symbolic link pointing out) is not found.  Nothing can be written: every write, create,
remove, rename or truncate is refused (:meth:`FileTree.write_error`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from mavsim_core.mavftp import DirEntry, Err, crc32

CRC_CHUNK_BYTES = 1 << 16  # CalcFileCRC32 reads a file on disk this much at a time


class FtpError(Exception):
    """A request refused with a MAVLink FTP error code (``err``)."""

    def __init__(self, err: Err, what: str = "") -> None:
        super().__init__(f"{err.name}: {what}" if what else err.name)
        self.err = err


class OpenFile(Protocol):
    """A file open for reading: its size when opened (bytes) and reads at any offset."""

    @property
    def size(self) -> int: ...

    def read(self, offset: int, n: int) -> bytes: ...

    def close(self) -> None: ...


@dataclass
class MemoryFile:
    """A file held in memory (component metadata)."""

    content: bytes

    @property
    def size(self) -> int:
        return len(self.content)

    def read(self, offset: int, n: int) -> bytes:
        return self.content[offset : offset + n]

    def close(self) -> None:
        pass


class DiskFile:
    """A file on disk, open until :meth:`close`; reads past ``size`` see what was written since (a log
    being recorded)."""

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_RDONLY)
        self.size = os.fstat(self._fd).st_size

    def read(self, offset: int, n: int) -> bytes:
        return os.pread(self._fd, n, offset)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


@dataclass(frozen=True)
class _Node:
    """What a path names: a directory (``entries`` lists it) or a file (on disk or in memory)."""

    is_dir: bool
    disk: Path | None = None  # a file or directory on disk
    memory: bytes | None = None  # a file in memory
    mount: str | None = None  # a directory in memory; None with neither: the root


class FileTree:
    """The read-only tree: ``disk`` mounts name -> directory (None: absent), ``memory`` mounts
    name -> {file name: content}.  The root lists the disk mounts that exist, then the memory ones."""

    def __init__(self, disk: dict[str, Path | None], memory: dict[str, dict[str, bytes]]) -> None:
        self.disk = {name: path for name, path in disk.items() if path is not None}
        self.memory = memory

    # -- resolution
    def _node(self, path: str) -> _Node | None:
        parts = [p for p in path.replace("\\", "/").split("/") if p not in ("", ".")]
        if ".." in parts:
            return None
        if not parts:
            return _Node(is_dir=True)
        mount, rest = parts[0], parts[1:]
        if mount in self.memory:
            files = self.memory[mount]
            if not rest:
                return _Node(is_dir=True, mount=mount)
            return _Node(is_dir=False, memory=files[rest[0]]) if len(rest) == 1 and rest[0] in files else None
        base = self.disk.get(mount)
        if base is None or not base.is_dir():
            return None
        target = base.joinpath(*rest)
        try:
            real_base, real = base.resolve(), target.resolve()
        except OSError:
            return None
        if real != real_base and real_base not in real.parents:
            return None  # a link out of the mount
        if real.is_dir():
            return _Node(is_dir=True, disk=real)
        return _Node(is_dir=False, disk=real) if real.is_file() else None

    def _find(self, path: str) -> _Node:
        node = self._node(path)
        if node is None:
            raise FtpError(Err.FILE_NOT_FOUND, path)
        return node

    # -- reading
    def list(self, path: str) -> list[DirEntry]:
        """The entries of directory ``path``, directories and files sorted by name (FtpError:
        FILE_NOT_FOUND, or FAIL for a file)."""
        node = self._find(path)
        if not node.is_dir:
            raise FtpError(Err.FAIL, f"{path} is not a directory")
        if node.disk is not None:
            out = []
            with os.scandir(node.disk) as it:
                for e in it:
                    if e.is_dir(follow_symlinks=False):
                        out.append(DirEntry(e.name, True))
                    elif e.is_file(follow_symlinks=False):
                        out.append(DirEntry(e.name, False, e.stat(follow_symlinks=False).st_size))
            return sorted(out, key=lambda d: (not d.is_dir, d.name))
        if node.mount is not None:
            return [DirEntry(n, False, len(c)) for n, c in sorted(self.memory[node.mount].items())]
        disk = [DirEntry(n, True) for n, p in self.disk.items() if p.is_dir()]
        return disk + [DirEntry(n, True) for n in self.memory]

    def open(self, path: str) -> OpenFile:
        """File ``path`` open for reading (FtpError: FILE_NOT_FOUND, FAIL for a directory)."""
        node = self._find(path)
        if node.is_dir:
            raise FtpError(Err.FAIL, f"{path} is a directory")
        if node.memory is not None:
            return MemoryFile(node.memory)
        assert node.disk is not None
        return DiskFile(node.disk)

    def crc32(self, path: str) -> int:
        """MAVLink's CRC32 of file ``path`` (as :meth:`open` fails)."""
        f = self.open(path)
        try:
            crc, offset = 0, 0
            while chunk := f.read(offset, CRC_CHUNK_BYTES):
                crc = crc32(chunk, crc)
                offset += len(chunk)
            return crc
        finally:
            f.close()

    # -- writing (refused)
    def write_error(self, path: str, creates: bool) -> Err:
        """Why changing ``path`` is refused: FILE_PROTECTED if it exists (everything here is read-only)
        or, for a request that ``creates`` it (CreateFile, OpenFileWO, CreateDirectory), if its
        directory exists; FILE_NOT_FOUND otherwise."""
        if self._node(path) is not None:
            return Err.FILE_PROTECTED
        parent = path.rstrip("/").rpartition("/")[0]
        return Err.FILE_PROTECTED if creates and self._node(parent) is not None else Err.FILE_NOT_FOUND
