"""The committed experiment pages say what the current code computes.

The fast pages (a few seconds to half a minute each; every page with ``make fresh``) are
rerun with the seed they were made with and every number and text of their
``results.json`` is compared with the committed one, and the words of their page (its
HTML with every number masked: the numbers are the results') with the committed page's; a
page made by older code fails here until it is regenerated (``make reproduce``, or ``python -m contactlab.portable contactlab
reproduce NAME --out reports --seed S``).  Wall-clock times and the page's own path are
not results.  A refactor that leaves results unchanged passes.  Both run in :mod:`contactlab.portable`'s
environment, so the same code gives the same numbers on x86-64 Linux machines with AVX2
and FMA, of any make.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from contactlab.portable import environment

REPO = Path(__file__).resolve().parents[1]
FAST = ("ph-demo", "impact-envelope", "impact-spectrogram", "ar-fit", "hf-models",
        "constraint-degree", "cartesian-estimation", "texture-labelling",
        "constraint-direction", "guarded-move-multi", "hf-recognition", "ph-roc",
        "polygon-estimation")
#: the pages of 40 s to 6 min: checked by ``make fresh`` (CONTACTLAB_FRESH_ALL=1)
SLOW = ("maze", "guarded-move", "datasets", "guarded-move-actions", "stroke-segmentation",
        "apparatus")
PAGES = FAST + (SLOW if os.environ.get("CONTACTLAB_FRESH_ALL") else ())
#: wall-clock times and rates, and the page's own path: not results
NOT_RESULTS = ("wall_time_s", "html", "pdf", "seconds", "elapsed_s", "blocks_per_s_likelihood",
               "estimate_ms_median", "hmm_decode_s", "runtime_s", "per_trial_s")


def _flat(d, prefix=""):
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            if k not in NOT_RESULTS:
                out.update(_flat(v, f"{prefix}/{k}"))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            out.update(_flat(v, f"{prefix}[{i}]"))
    else:
        out[prefix] = d
    return out


#: a number in a page's text: compared through results.json, where wall-clock times are not
_NUMBER = re.compile(r"[-+]?\d+(?:[.,]\d+)*(?:[eE][-+]?\d+)?")


def _words(html: str) -> list[str]:
    """A page's lines (one tag a line) with every number masked."""
    return _NUMBER.sub("#", html.replace("><", ">\n<")).splitlines()


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-7,
                                                                 abs_tol=1e-12)
    return a == b


@pytest.mark.parametrize("name", PAGES)
def test_committed_page_matches_the_code(name, tmp_path):
    committed = json.loads((REPO / "reports" / name / "results.json").read_text())
    seed = committed.get("seed", 1)
    r = subprocess.run([sys.executable, "-m", "contactlab", "reproduce", name, "--out",
                        str(tmp_path), "--seed", str(seed), "-q"], env=environment(),
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    fresh = json.loads((tmp_path / name / "results.json").read_text())
    a, b = _flat(committed), _flat(fresh)
    stale = sorted(k for k in set(a) | set(b) if not _same(a.get(k), b.get(k)))
    again = (f"regenerate it with 'python -m contactlab.portable contactlab reproduce {name} "
             f"--out reports --seed {seed}'")
    assert not stale, (f"reports/{name} is older than the code ({len(stale)} results differ, "
                       f"e.g. {stale[:3]}): {again}")
    changed = _changed_words((REPO / "reports" / name / "index.html").read_text("utf-8"),
                             (tmp_path / name / "index.html").read_text("utf-8"))
    assert not changed, (f"reports/{name}/index.html says other words than the code writes "
                         f"now ({len(changed)} lines, e.g. {changed[:2]}): {again}")


def _changed_words(old: str, new: str) -> list[str]:
    """The lines whose words differ between two pages (numbers masked)."""
    return [d for d in difflib.unified_diff(_words(old), _words(new), lineterm="", n=0)
            if d[:1] in "+-" and d[:3] not in ("+++", "---")]


def test_a_page_with_other_words_is_stale_but_other_timings_are_not():
    page = "<p>Accuracy 0.657; the test ran 8377 blocks/s.</p><td>28.07 s</td>"
    assert _changed_words(page, page.replace("8377", "9564").replace("28.07", "0.26")) == []
    assert _changed_words(page, page.replace("Accuracy", "Precision"))
    assert _changed_words(page, page.replace("</td>", "</td><td>missed</td>"))


def test_the_portable_environment_takes_effect():
    r = subprocess.run([sys.executable, "-m", "contactlab.portable", "--check"],
                       env=environment(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    # without it, numba compiles for the host and the check says so
    from contactlab.portable import ENV

    native = {k: v for k, v in os.environ.items() if k not in ENV}
    r = subprocess.run([sys.executable, "-m", "contactlab.portable", "--check"],
                       env=native, capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "numba compiles for the host" in r.stderr
    # the launcher runs nothing when the environment does not take effect
    broken = {**native, "PYTHONPATH": os.pathsep.join(sys.path)}
    r = subprocess.run([sys.executable, "-c", (
        "import sys, contactlab.portable as p; p.ENV['NUMBA_CPU_NAME'] = 'znver4'; "
        "sys.exit(p._main([sys.executable, '-c', 'print(1)']))")],
        env=broken, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "did not take effect" in r.stderr and r.stdout == ""
