"""The kernel cache follows every source file: an edited helper in another file is
compiled afresh, an unchanged source reuses its folder, a user's NUMBA_CACHE_DIR wins."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time

from contactlab.kernel_cache import STAMP, UNUSED_DAYS, cache_dir, configure, source_digest

KERNEL = textwrap.dedent("""
    import numba
    from pkg.helper import step

    @numba.njit(cache=True)
    def run(x):
        return step(x) + 1.0
""")
HELPER = textwrap.dedent("""
    import numba

    @numba.njit(cache=True)
    def step(x):
        return {value} * x
""")


def _write_pkg(root, value):
    pkg = root / "pkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernel.py").write_text(KERNEL)
    (pkg / "helper.py").write_text(HELPER.format(value=value))
    return pkg


def _run(root, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, "-c", "from pkg.kernel import run; print(run(2.0))"],
                         env=env, capture_output=True, text=True, check=True)
    return float(out.stdout)


def test_an_edited_helper_in_another_file_is_compiled_afresh(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    pkg = _write_pkg(src, 3.0)
    first = cache_dir(pkg, tmp_path / "cache")
    assert _run(src, first) == 7.0
    assert any(first.rglob("*.nbi"))                    # compiled and cached there
    assert cache_dir(pkg, tmp_path / "cache") == first  # unchanged source: same folder
    time.sleep(0.01)
    (pkg / "helper.py").write_text(HELPER.format(value=5.0))
    second = cache_dir(pkg, tmp_path / "cache")
    assert second != first
    assert _run(src, second) == 11.0


def test_digest_reads_paths_sizes_and_times(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    d0 = source_digest(tmp_path)
    assert source_digest(tmp_path) == d0 and len(d0) == 16
    (tmp_path / "b.py").write_text("")
    assert source_digest(tmp_path) != d0


def test_configure_sets_one_folder_removes_unused_ones_and_respects_the_user(tmp_path,
                                                                          monkeypatch):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "a.py").write_text("x = 1\n")
    base = tmp_path / "cache"
    stale, recent = base / "0123456789abcdef", base / "fedcba9876543210"
    for d in (stale, recent):
        d.mkdir(parents=True)
        (d / STAMP).touch()
    old = time.time() - (UNUSED_DAYS + 1) * 86400.0
    os.utime(stale / STAMP, (old, old))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    d = configure(tmp_path / "src", base)
    assert d == cache_dir(tmp_path / "src", base) and d.is_dir()
    assert not stale.exists() and recent.exists()     # another checkout's, still in use
    assert os.environ["NUMBA_CACHE_DIR"] == str(d)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert configure(tmp_path / "src", base) is None
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")


def test_no_folder_no_setting(tmp_path, monkeypatch):
    (tmp_path / "src").mkdir()
    blocker = tmp_path / "file"
    blocker.write_text("")                      # a file where the folder should go
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert configure(tmp_path / "src", blocker / "numba") is None
    assert "NUMBA_CACHE_DIR" not in os.environ
