"""``make bench``: run every ``benchmarks/bench_*.py`` and print ratios against peers.

Each module has ``run() -> list[dict]`` with keys ``name``, ``ours_s``, ``peer``,
``peer_s``, ``ratio`` (peer time / our time; > 1 means we are faster) and
``notes``. All rows come from one run on one machine; the table is also
written to ``.bench/latest.json``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import pkgutil
import platform
import sys
from pathlib import Path

import benchmarks


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("-k", default="", help="only modules whose name contains this")
    args = parser.parse_args(argv)
    names = sorted(m.name for m in pkgutil.iter_modules(benchmarks.__path__)
                   if m.name.startswith("bench_") and args.k in m.name)
    rows = []
    print(f"# contactlab benchmarks on {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}")
    for name in names:
        module = importlib.import_module(f"benchmarks.{name}")
        print(f"## {name}", flush=True)
        for row in module.run():
            rows.append({"module": name, **row})
            ratio = row.get("ratio")
            peer = row.get("peer") or "-"
            peer_s = row.get("peer_s")
            line = f"  {row['name']:<48}"
            if row.get("ours_s") is not None:
                line += f" ours {row['ours_s'] * 1e3:10.3f} ms"
            if peer_s is not None and ratio is not None:
                line += f"   {peer:<28} {peer_s * 1e3:10.3f} ms   ratio {ratio:8.1f}x"
            print(line)
            if row.get("notes"):
                print(f"      {row['notes']}")
    out = Path(".bench")
    out.mkdir(exist_ok=True)
    (out / "latest.json").write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
