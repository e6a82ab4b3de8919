"""In-place writes that a kill undoes: the rollback journal of an archive being recorded.

An incremental archive (acquisition, import) is written in place once its first
trial is finished, so that the finished trials survive any signal, SIGKILL
included, at a write cost linear in trials. HDF5 updates in place are not
crash-safe on their own (a killed writer can leave a file whose superblock and
object headers disagree), so HDF5 writes the file through a
:class:`JournaledFile`: before a byte that the last commit left is overwritten
or cut off by a truncation, its page is copied to the journal beside the file
(``.NAME.PID-XXXXXXXX_journal.tmp``); bytes written past the committed size
need no copy. :meth:`JournaledFile.commit` makes the current contents the ones
to return to.

:func:`rollback` puts the file back to its last commit, byte for byte: it
writes the saved pages back and truncates the file to the committed size. The
writer calls it when it stops with a trial unfinished, a second signal calls it
before quitting (plain ``os`` calls: safe from a signal handler), and after a
SIGKILL the next run on the archive calls it before anything reads the file
(:func:`contactlab.fileio.remove_stale_temp_files`).

Journal layout: a header (magic, committed size, the file's device and inode,
CRC-32 of these), then records (offset, length, CRC-32, the page's bytes). The
header is written right after a commit, before any further write, so a torn
header means the file is at a commit; a record is written before its page is
overwritten, so a torn last record means the page was never overwritten. The
journal protects against a killed process (the kernel keeps what was written);
a commit also fsyncs the file.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import struct
import zlib
from pathlib import Path

MAGIC = b"CLJRNL1\n"
_HEADER = struct.Struct("<8sQQQI")
_RECORD = struct.Struct("<QII")
#: Granularity of the saved copies (bytes).
PAGE = 4096
#: The journal of a file being written is its temporary name with this ending.
SUFFIX = "_journal.tmp"


def journal_path_for(tmp_path: str | os.PathLike) -> Path:
    """The journal beside the file first written as ``tmp_path`` (``.x.h5.PID-XXXX.tmp``)."""
    tmp_path = Path(tmp_path)
    return tmp_path.with_name(tmp_path.name[:-len(".tmp")] + SUFFIX)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        if n <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        view = view[n:]


class JournaledFile(io.RawIOBase):
    """A file for h5py's ``fileobj`` driver whose writes since the last commit can be
    undone (see the module notes). Until :meth:`start_journal` nothing is saved: the
    file is new and a kill leaves it as a temporary file."""

    def __init__(self, path: str | os.PathLike):
        super().__init__()
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        self._pos = 0
        self._jfd: int | None = None
        self.journal: Path | None = None
        self._committed = 0
        self._saved: set[int] = set()

    # -- the file interface h5py uses ------------------------------------------------
    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        if whence == os.SEEK_SET:
            self._pos = offset
        elif whence == os.SEEK_CUR:
            self._pos += offset
        else:
            self._pos = os.fstat(self._fd).st_size + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buffer) -> int:
        data = os.pread(self._fd, len(buffer), self._pos)
        buffer[:len(data)] = data
        self._pos += len(data)
        return len(data)

    def write(self, data) -> int:
        data = memoryview(data).cast("B")
        self._save(self._pos, self._pos + len(data))
        done = 0
        while done < len(data):
            n = os.pwrite(self._fd, data[done:], self._pos + done)
            if n <= 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path))
            done += n
        self._pos += done
        return done

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        self._save(size, self._committed)
        os.ftruncate(self._fd, size)
        return size

    def flush(self) -> None:
        pass

    def close(self) -> None:
        if not self.closed:
            for fd in (self._jfd, self._fd):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            self._jfd = None
        super().close()

    # -- commits ---------------------------------------------------------------------
    def sync(self) -> None:
        """Push the file's contents to the disk."""
        os.fsync(self._fd)

    def start_journal(self, journal: str | os.PathLike) -> None:
        """From now on save what the current contents would lose (the first commit)."""
        self.journal = Path(journal)
        self._jfd = os.open(self.journal, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND,
                            0o600)
        self.commit()

    def commit(self) -> None:
        """Make the file's current contents the ones :func:`rollback` returns to."""
        self.sync()
        self._committed = os.fstat(self._fd).st_size
        self._saved.clear()
        if self._jfd is not None:
            st = os.fstat(self._fd)
            os.ftruncate(self._jfd, 0)
            head = _HEADER.pack(MAGIC, self._committed, st.st_dev, st.st_ino, 0)[:-4]
            _write_all(self._jfd, head + struct.pack("<I", zlib.crc32(head)))

    def finish(self) -> None:
        """The file is whole: push it to the disk, close it and drop the journal."""
        self.sync()
        journal = self.journal
        self.close()
        if journal is not None:
            with contextlib.suppress(FileNotFoundError):
                journal.unlink()

    def _save(self, start: int, end: int) -> None:
        """Copy to the journal the committed pages in [start, end) not yet saved."""
        if self._jfd is None:
            return
        end = min(end, self._committed)
        if end <= start:
            return
        for page in range(start // PAGE, (end + PAGE - 1) // PAGE):
            if page in self._saved:
                continue
            offset = page * PAGE
            data = os.pread(self._fd, min(PAGE, self._committed - offset), offset)
            _write_all(self._jfd, _RECORD.pack(offset, len(data), zlib.crc32(data)) + data)
            self._saved.add(page)


def _read_journal(journal: Path):
    """(committed size, device, inode, [(offset, bytes)]) or None for a torn header."""
    data = journal.read_bytes()
    if len(data) < _HEADER.size:
        return None
    magic, size, dev, ino, crc = _HEADER.unpack_from(data)
    if magic != MAGIC or crc != zlib.crc32(data[:_HEADER.size - 4]):
        return None
    pages, at = [], _HEADER.size
    while at + _RECORD.size <= len(data):
        offset, length, crc = _RECORD.unpack_from(data, at)
        page = data[at + _RECORD.size:at + _RECORD.size + length]
        if len(page) < length or zlib.crc32(page) != crc:
            break  # torn: written when the process died, before its page was touched
        pages.append((offset, page))
        at += _RECORD.size + length
    return size, dev, ino, pages


def rollback(path: str | os.PathLike, journal: str | os.PathLike) -> bool:
    """Put ``path`` back to the last commit ``journal`` holds and remove the journal.

    Returns whether the file was changed back (False: the journal was torn at a
    commit, or belongs to another file now at that name, or the file is gone).
    Raises OSError when the file cannot be written.
    """
    journal = Path(journal)
    try:
        content = _read_journal(journal)
    except FileNotFoundError:
        return False
    done = False
    if content is not None:
        size, dev, ino, pages = content
        try:
            st = os.stat(path)
        except FileNotFoundError:
            st = None
        if st is not None and (st.st_dev, st.st_ino) == (dev, ino):
            fd = os.open(path, os.O_WRONLY)
            try:
                for offset, page in pages:
                    os.pwrite(fd, page, offset)
                os.ftruncate(fd, size)
                os.fsync(fd)
            finally:
                os.close(fd)
            done = True
    with contextlib.suppress(FileNotFoundError):
        journal.unlink()
    return done
