"""Writing a run's files: atomically, with the user's permissions, and only that run's files.

A run (``roundabout solve``, ``simulate``) writes its files into a hidden staging folder
beside the output folder; only when the run has finished are they moved into place, the
files an earlier run left there under the same known names removed, with SIGINT held off
for those few renames. So an interrupted or failed write leaves the folder as it was, and a
finished one holds this run's files only. Files get the mode a plain ``open`` would give
them under the process's umask (``tempfile.mkstemp`` alone makes them private, 0600).
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

# What a run of this project writes into its folder (docs/scenario-format.md,
# docs/closed-loop-format.md); an earlier run's files of these names are removed on commit.
RUN_FILES = (
    "summary.json",
    "trajectory.csv",
    "swept_path.geojson",
    "commonroad.xml",
    "closed_loop.csv",
    "runs.csv",
    "scenario.toml",
    "figure.png",
)
RUN_FOLDERS = ("optimum",)


def umask() -> int:
    """The process's file-creation mask (read by setting and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomically(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file and a rename, with the umask's mode.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder is made if missing.
    data : str or bytes
        Text (UTF-8) or bytes.

    Returns
    -------
    Path
        ``path``. On any error (or KeyboardInterrupt) the temporary file is removed and
        ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~umask())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode() if isinstance(data, str) else data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_files(folder: str | Path, files: dict[str, str | bytes]) -> None:
    """Write each ``name: data`` of ``files`` into ``folder`` by ``write_atomically``."""
    for name, data in files.items():
        write_atomically(Path(folder) / name, data)


@contextmanager
def run_folder(out: str | Path, keep: tuple[str, ...] = ()) -> Iterator[Path]:
    """A staging folder for one run's files, moved into ``out`` when the block ends normally.

    Parameters
    ----------
    out : str or Path
        The run's output folder (made if missing).

    Yields
    ------
    Path
        The staging folder to write into. If the block raises (a failure, KeyboardInterrupt)
        it is removed and ``out`` is untouched; otherwise its files replace ``out``'s, and
        files of an earlier run (``RUN_FILES``, ``RUN_FOLDERS``) not written again are removed.
    keep : tuple of str
        Names in ``out`` the run writes separately and that are not removed (a closed loop
        keeps the ``optimum`` folder its open-loop solve wrote).
    """
    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=parent, prefix=f".{out.name}.", suffix=".partial"))
    try:
        yield stage
        _commit(stage, out, keep)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _commit(stage: Path, out: Path, keep: tuple[str, ...] = ()) -> None:
    """Move the staged files into ``out`` and remove the earlier run's others, SIGINT held off."""
    blocked = _block_sigint()
    try:
        out.mkdir(parents=True, exist_ok=True)
        _remove_earlier_run(out, stage, keep)
        for src in sorted(p for p in stage.rglob("*") if p.is_file()):
            dest = out / src.relative_to(stage)
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dest)
    finally:
        if blocked:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _remove_earlier_run(out: Path, stage: Path, keep: tuple[str, ...]) -> None:
    folders = [name for name in RUN_FOLDERS if name not in keep]
    for folder in (out, *(out / name for name in folders)):
        for name in RUN_FILES:
            kept = folder == out and name in keep
            if (folder / name).is_file() and not kept and not (stage / folder.relative_to(out) / name).exists():
                (folder / name).unlink()
    for name in folders:
        folder = out / name
        if folder.is_dir() and not (stage / name).exists() and not any(folder.iterdir()):
            folder.rmdir()


def _block_sigint() -> bool:
    """Hold SIGINT back (main thread only); True if it was blocked here."""
    try:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    except (AttributeError, ValueError, OSError):
        return False
    return True


__all__ = ["RUN_FILES", "RUN_FOLDERS", "run_folder", "umask", "write_atomically", "write_files"]
