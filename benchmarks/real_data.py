"""Where the real recordings of other groups are on this machine (never in the project).

``$CONTACTLAB_REAL_DATA``, else ``../shared/data/real`` beside the repository.  The
benchmarks that read them skip with one line when :func:`real_data_dir` gives None.
"""

from __future__ import annotations

import os
from pathlib import Path

SKIPPED = "  skipped: no real recordings (../shared/data/real or $CONTACTLAB_REAL_DATA)"


def real_data_dir(*needs: str) -> Path | None:
    """The recordings' folder when it holds every subfolder in ``needs``; else None."""
    env = os.environ.get("CONTACTLAB_REAL_DATA")
    root = Path(env) if env else Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "real"
    return root if root.is_dir() and all((root / n).is_dir() for n in needs) else None
