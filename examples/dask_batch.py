#!/usr/bin/env python3
"""Smooth and resample a folder of meshes with g1tess on a Dask cluster.

Every mesh of INPUT_DIR (.obj, .pn, .ply, .stl, .glb, .gltf) becomes one smooth surface
(the chosen scheme, G1 by default) resampled on the grid of --level and written to
OUTPUT_DIR/<name>.<format>, and one row of a summary table (OUTPUT_DIR/summary.csv and
summary.md) with the input and output sizes, the continuity statistics and the time. A mesh
that fails (unreadable, broken, ...) gets a row with its error and the run goes on; the exit
status is 0 unless --strict is given and some mesh failed.

Here: a LocalCluster of --workers processes (two by default). On a real cluster, start a
scheduler and workers that can import g1tess and see both folders (a shared filesystem),
and pass the scheduler's address:

    python examples/dask_batch.py meshes/ out/                       # LocalCluster, 2 workers
    python examples/dask_batch.py meshes/ out/ --scheduler tcp://head:8786
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path
from typing import Any, Dict, List

EXTENSIONS = {".obj", ".pn", ".ply", ".stl", ".glb", ".gltf"}

COLUMNS = [
    "mesh",
    "status",
    "triangles_in",
    "vertices_in",
    "output",
    "vertices_out",
    "triangles_out",
    "max_one_minus_abs_cos",
    "max_gap_relative",
    "crease_edges",
    "boundary_edges",
    "seconds",
    "worker",
    "error",
]


def smooth_one(path: str, out_dir: str, scheme: str, level: int, fmt: str) -> Dict[str, Any]:
    """Runs on a worker: loads, smooths, resamples and writes one mesh; never raises (a
    failure is returned as the row's status and error)."""
    import socket

    import g1tess

    row: Dict[str, Any] = {c: "" for c in COLUMNS}
    row["mesh"] = os.path.basename(path)
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    start = time.perf_counter()
    try:
        mesh = g1tess.load(path)
        row["triangles_in"] = len(mesh.triangles)
        row["vertices_in"] = len(mesh.vertices)
        out = os.path.join(out_dir, f"{Path(path).stem}.{fmt}")
        nv, nt = mesh.write_tessellation(out, scheme=scheme, level=level)
        stats = mesh.stats(scheme)
        row.update(
            status="ok",
            output=os.path.basename(out),
            vertices_out=nv,
            triangles_out=nt,
            max_one_minus_abs_cos=f"{stats['max_one_minus_abs_cos']:.3e}",
            max_gap_relative=f"{stats['max_gap_relative']:.3e}",
            crease_edges=stats["crease_edges"],
            boundary_edges=stats["boundary_edges"],
        )
    except Exception as e:  # noqa: BLE001 - every failure becomes a row
        row.update(status="failed", error=f"{type(e).__name__}: {e}")
    row["seconds"] = f"{time.perf_counter() - start:.2f}"
    return row


def write_tables(rows: List[Dict[str, Any]], out_dir: Path) -> None:
    with open(out_dir / "summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    cell = lambda v: str(v).replace("|", "\\|").replace("\n", " ")  # noqa: E731
    lines = [
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    lines += ["| " + " | ".join(cell(r[c]) for c in COLUMNS) + " |" for r in rows]
    (out_dir / "summary.md").write_text("\n".join(lines) + "\n")


def main(argv: List[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input_dir", type=Path)
    ap.add_argument("output_dir", type=Path)
    ap.add_argument("--scheduler", help="address of a running Dask scheduler "
                    "(default: start a LocalCluster)")
    ap.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    ap.add_argument("--scheme", default="g1")
    ap.add_argument("--level", type=int, default=8)
    ap.add_argument("--format", default="ply", choices=["ply", "obj", "stl", "glb"])
    ap.add_argument("--strict", action="store_true", help="exit 1 if any mesh failed")
    a = ap.parse_args(argv)

    from dask.distributed import Client, LocalCluster, as_completed

    paths = sorted(
        str(p.resolve()) for p in a.input_dir.iterdir()
        if p.is_file() and p.suffix.lower() in EXTENSIONS
    )
    if not paths:
        print(f"error: no meshes in {a.input_dir}", file=sys.stderr)
        return 2
    a.output_dir.mkdir(parents=True, exist_ok=True)
    out_dir = str(a.output_dir.resolve())

    if a.scheduler:
        cluster = None
        client = Client(a.scheduler)
    else:
        # One thread per worker process: g1tess already uses every core of its machine
        # (rayon), and releases the GIL while it works.
        cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        futures = client.map(smooth_one, paths, out_dir=out_dir, scheme=a.scheme,
                             level=a.level, fmt=a.format, pure=False)
        by_future = dict(zip(futures, paths))
        rows = []
        for fut in as_completed(futures):
            try:
                row = fut.result()
            except Exception as e:  # noqa: BLE001 - a worker that died, say
                row = {c: "" for c in COLUMNS}
                row.update(mesh=os.path.basename(by_future[fut]), status="failed",
                           error=f"{type(e).__name__}: {e}")
            print(f"{row['status']:>6}  {row['mesh']}  {row['error']}", file=sys.stderr)
            rows.append(row)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    rows.sort(key=lambda r: r["mesh"])
    write_tables(rows, a.output_dir)
    failed = sum(r["status"] != "ok" for r in rows)
    print(f"{len(rows) - failed} of {len(rows)} meshes done; summary in "
          f"{a.output_dir / 'summary.csv'} and summary.md", file=sys.stderr)
    return 1 if (a.strict and failed) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
