"""Files that a kill cannot leave half-written: the run directory's report, the mapper's and the
tag tracker's saved state (docs/faults.md)."""
from __future__ import annotations

import os
from pathlib import Path


def write_atomic(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` (text or bytes) to ``path`` through a temporary file in the same directory,
    flushed to disk, then renamed over ``path`` (os.replace): a reader, or a node restarted
    after a SIGKILL, sees no file or the whole of it, never a part. On failure (a full disk)
    the temporary file is removed, ``path`` is left as it was and the OSError propagates."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")   # same file system: the rename is atomic
    try:
        with open(tmp, "wb" if isinstance(data, bytes) else "w") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path
