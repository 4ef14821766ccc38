"""Benchmark: the navigation pipeline on a building-size S3DIS area (time and peak memory per stage).

An area in S3DIS's on-disk layout at the size of its Area_5 (``write_building`` of ``s3dis_building.py``, beside
this script: 4·10^7 points, 56 rooms along a hallway, doors, furniture, clutter; ``--points N``, ``--rooms R``) is
written into a temporary folder (or ``--area DIR`` reuses one), then every stage of the pipeline runs in its own
child process, so that each peak RSS is that stage's alone (``getrusage`` of the child, through
``_bench_common.RSS_WRAPPER``):

1. writing the area (``write_building``);
2. the maps, streamed (``build_maps(folder)``: one room at a time, two passes); inside it, by cProfile, the first
   pass (bounding box, ceiling cuts, floor heights), the binning pass, the obstacle inflation and the topology's
   passages (edges);
3. the maps, in memory (``build_maps(read_area(folder))``, the old route; skipped with ``--no-memory-route`` or
   when the available memory is below 250 bytes per point) and whether its arrays and topology equal the
   streamed ones (the agreement; a difference exits with status 1);
4. the topology queried: rooms, edges, whether the room graph is connected and the room-level path from the
   lobby to each HR office;
5. the candidate routes lobby_1 -> office_1, office_2 (``candidate_routes``), the equal-distance check and the
   two route images (``route_image``).

The maps of stage 2 are passed to stages 4-5 as a pickle. Usage:
``python benchmarks/bench_navigation.py [--quick] [--points N] [--rooms R] [--area DIR] [--resolution M]
[--no-memory-route] [--no-profile] [--output FILE.md]``; ``--quick``: 10^6 points over 20 rooms at 0.1 m, in seconds.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pickle
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench_common import RSS_WRAPPER, finish, fmt_time, machine_line, memory_info, table  # noqa: E402

FULL = dict(points=40_000_000, rooms=56, resolution=0.05)
QUICK = dict(points=1_000_000, rooms=20, resolution=0.1)
GOALS = ("office_1", "office_2")
GRID_FIELDS = ("top_height", "top_color", "top_category", "free", "traversable", "room_labels", "ceiling_z")
BYTES_PER_POINT_IN_MEMORY = 250  # the in-memory route's peak is about 150 bytes per point; keep a margin


# -- the stages (each runs in a child process: ``--stage NAME``) -------------------------------------------


def _stage_write(args: argparse.Namespace) -> dict:
    from s3dis_building import write_building

    folder = Path(args.area)
    t0 = time.perf_counter()
    write_building(folder.parent, rooms=args.rooms, points=args.points, area=folder.name)
    seconds = time.perf_counter() - t0
    size = sum(f.stat().st_size for f in folder.rglob("*.txt"))
    return {"seconds": seconds, "bytes": size}


def _profiled(fn, names: tuple[str, ...]) -> tuple[object, dict[str, float]]:
    """``fn()`` under cProfile, and the cumulative time of the functions called ``names``."""
    prof = cProfile.Profile()
    result = prof.runcall(fn)
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    found = {n: 0.0 for n in names}
    for (_, _, func), (_, _, _, cum, _) in stats.items():
        if func in found:
            found[func] = max(found[func], cum)
    return result, found


def _stage_stream(args: argparse.Namespace) -> dict:
    from fairaudit.experiments.navigation import build_maps

    t0 = time.perf_counter()
    maps = build_maps(args.area, resolution=args.resolution)
    seconds = time.perf_counter() - t0
    with open(Path(args.work) / "maps.pickle", "wb") as f:
        pickle.dump(maps, f, protocol=pickle.HIGHEST_PROTOCOL)
    out = {"seconds": seconds, "shape": list(maps.shape), "rooms": len(maps.rooms), "floor_z": maps.floor_z}
    if args.child_profile:
        names = ("_scan", "_stream_grids", "_inflate", "_add_passages", "read_points")
        _, found = _profiled(lambda: build_maps(args.area, resolution=args.resolution), names)
        out["profile"] = found
    return out


def _stage_reader(args: argparse.Namespace) -> dict:
    return _readers(Path(args.area))


def _readers(area: Path) -> dict:
    """Seconds to read the largest room file with ``read_points`` (pandas' C parser) and with pyarrow.csv."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from fairaudit.experiments.navigation import read_points

    biggest = max(area.glob("*/*.txt"), key=lambda f: f.stat().st_size)
    times: dict[str, list[float]] = {"pandas": [], "arrow": []}
    for _ in range(2):  # alternated, twice: the file is in the page cache for both
        t0 = time.perf_counter()
        rows, _ = read_points(biggest)
        t1 = time.perf_counter()
        table = pacsv.read_csv(
            biggest,
            read_options=pacsv.ReadOptions(autogenerate_column_names=True, block_size=1 << 22),
            parse_options=pacsv.ParseOptions(delimiter=" "),
            convert_options=pacsv.ConvertOptions(column_types={f"f{i}": pa.float64() for i in range(6)}),
        )
        arrow = np.column_stack([c.to_numpy() for c in table.columns])
        t2 = time.perf_counter()
        times["pandas"].append(t1 - t0)
        times["arrow"].append(t2 - t1)
    same = bool(np.array_equal(rows, arrow))
    return {"file": biggest.name, "points": len(rows), "same": same, **{k: min(v) for k, v in times.items()}}


def _stage_memory(args: argparse.Namespace) -> dict:
    from fairaudit.experiments.navigation import build_maps, read_area

    t0 = time.perf_counter()
    area = read_area(args.area)
    t1 = time.perf_counter()
    maps = build_maps(area, resolution=args.resolution)
    t2 = time.perf_counter()
    with open(Path(args.work) / "maps.pickle", "rb") as f:
        streamed = pickle.load(f)
    return {"read": t1 - t0, "build": t2 - t1, "seconds": t2 - t0, "differences": _differences(maps, streamed)}


def _differences(a, b) -> list[str]:
    """The fields where two Maps differ (grids exactly; topology attributes to 1e-9)."""
    out = [f for f in GRID_FIELDS if not np.array_equal(getattr(a, f), getattr(b, f), equal_nan=f == "top_height")]
    for f in ("origin", "shape", "rooms", "floor_z"):
        if getattr(a, f) != getattr(b, f):
            out.append(f)
    na, nb = dict(a.topology.nodes(data=True)), dict(b.topology.nodes(data=True))
    if na.keys() != nb.keys() or any(
        not np.allclose(np.r_[na[k]["centre"], na[k]["bbox"]], np.r_[nb[k]["centre"], nb[k]["bbox"]], 0, 1e-9)
        or na[k]["free_cells"] != nb[k]["free_cells"]
        or na[k]["category"] != nb[k]["category"]
        for k in na
    ):
        out.append("topology nodes")
    if sorted(a.topology.edges(data=True)) != sorted(b.topology.edges(data=True)):
        out.append("topology edges")
    return out


def _stage_routes(args: argparse.Namespace) -> dict:
    import networkx as nx

    from fairaudit.experiments.navigation import candidate_routes, check_equal_distance, route_image

    with open(Path(args.work) / "maps.pickle", "rb") as f:
        maps = pickle.load(f)
    t0 = time.perf_counter()
    graph = maps.topology
    room_paths = [nx.shortest_path(graph, "lobby_1", g) for g in GOALS]
    connected = nx.is_connected(graph)
    t1 = time.perf_counter()
    routes = candidate_routes(maps, "lobby_1", list(GOALS))
    t2 = time.perf_counter()
    check = check_equal_distance(routes)
    t3 = time.perf_counter()
    images = [route_image(maps, r, i + 1) for i, r in enumerate(routes)]
    t4 = time.perf_counter()
    return {
        "topology": t1 - t0,
        "edges": graph.number_of_edges(),
        "connected": connected,
        "room_paths": room_paths,
        "routes": t2 - t1,
        "lengths": [r.length for r in routes],
        "check": t3 - t2,
        "equal": bool(check.equal),
        "max_relative_difference": check.max_relative_difference,
        "images": t4 - t3,
        "image_bytes": [len(b) for b in images],
    }


def _warm() -> None:
    """Import what the stages use before anything is timed (imports are not part of a stage's time)."""
    import networkx  # noqa: F401
    import PIL.Image  # noqa: F401
    import pyarrow.csv  # noqa: F401
    import scipy.ndimage  # noqa: F401

    import fairaudit.experiments.navigation  # noqa: F401


STAGES = {
    "reader": _stage_reader,
    "write": _stage_write,
    "stream": _stage_stream,
    "memory": _stage_memory,
    "routes": _stage_routes,
}


# -- the parent: children, the report ----------------------------------------------------------------------


def _child(stage: str, args: argparse.Namespace) -> dict:
    """Run one stage in a child process; its own report plus the wrapper's wall time and peak RSS."""
    work = Path(args.work)
    wrapper, result = work / f"{stage}.rss.json", work / f"{stage}.json"
    cmd = [sys.executable, os.path.abspath(__file__), "--stage", stage, "--area", str(args.area)]
    cmd += ["--work", str(work), "--points", str(args.points), "--rooms", str(args.rooms)]
    cmd += ["--resolution", str(args.resolution)] + (["--profile"] if args.profile else [])
    subprocess.run([sys.executable, "-I", "-c", RSS_WRAPPER, str(wrapper), *cmd], check=True)
    rss = json.loads(wrapper.read_text())
    if rss["returncode"] != 0:
        raise RuntimeError(f"stage {stage} failed with status {rss['returncode']}")
    out = json.loads(result.read_text())
    out["rss"], out["wall"] = rss["rss"], rss["seconds"]
    return out


def _gb(n: float) -> str:
    return f"{n / 1e9:.2f} GB" if n >= 1e8 else f"{n / 1e6:.0f} MB"


def run(args: argparse.Namespace) -> tuple[str, list[str]]:
    t_start = time.perf_counter()
    written = not Path(args.area).exists()
    res: dict[str, dict] = {}
    if written:
        res["write"] = _child("write", args)
    res["stream"] = _child("stream", args)
    res["reader"] = _child("reader", args)
    info = memory_info()
    room_for_memory = info is None or info["available"] > BYTES_PER_POINT_IN_MEMORY * args.points
    if args.memory_route and room_for_memory:
        res["memory"] = _child("memory", args)
    res["routes"] = _child("routes", args)
    failures = [
        f"streamed maps differ from in-memory maps in {d}" for d in res.get("memory", {}).get("differences", [])
    ]
    if not res["routes"]["equal"]:
        failures.append(f"routes not equal: {res['routes']['lengths']}")
    return _report(args, res, written, room_for_memory, time.perf_counter() - t_start), failures


def _report(args: argparse.Namespace, res: dict, written: bool, room_for_memory: bool, total: float) -> str:
    rows = []
    if written:
        w = res["write"]
        rows.append(
            [
                "write the area (`write_building`)",
                fmt_time(w["seconds"]),
                _gb(w["rss"]),
                f"{w['bytes'] / 1e9:.2f} GB of text (room files + Annotations)",
            ]
        )
    s = res["stream"]
    rows.append(
        [
            "maps, streamed (`build_maps(folder)`)",
            fmt_time(s["seconds"]),
            _gb(s["rss"]),
            f"grid {s['shape'][0]} × {s['shape'][1]}, {s['rooms']} rooms",
        ]
    )
    for name, label in (
        ("_scan", "first pass: bbox, ceilings, floor heights"),
        ("_stream_grids", "both passes (reading + binning)"),
        ("read_points", "reading the text files (both passes)"),
        ("_inflate", "obstacle inflation"),
        ("_add_passages", "topology: edges (passages)"),
    ):
        if "profile" in s:
            rows.append([f"… {label}", fmt_time(s["profile"][name]), "", "cProfile, second run"])
    rd = res["reader"]
    rows.append(
        [
            f"… reading the largest room file ({rd['file']}, {rd['points']:,} points)",
            fmt_time(rd["pandas"]),
            "",
            f"`read_points` (pandas' C parser); pyarrow.csv {fmt_time(rd['arrow'])}; best of 2; same values: {rd['same']}",
        ]
    )
    if "memory" in res:
        m = res["memory"]
        same = "identical" if not m["differences"] else "DIFFERENT: " + ", ".join(m["differences"])
        rows.append(
            [
                "maps, in memory (`build_maps(read_area(folder))`)",
                fmt_time(m["seconds"]),
                _gb(m["rss"]),
                f"read {fmt_time(m['read'])} + build {fmt_time(m['build'])}; {same}",
            ]
        )
    r = res["routes"]
    rows.append(
        [
            "topology queried (room graph, paths)",
            fmt_time(r["topology"]),
            "",
            f"{r['edges']} edges, connected: {r['connected']}",
        ]
    )
    rows.append(
        [
            "candidate routes lobby_1 → office_1, office_2",
            fmt_time(r["routes"]),
            _gb(r["rss"]),
            "lengths " + ", ".join(f"{v:.2f} m" for v in r["lengths"]) + " (RSS: the whole child)",
        ]
    )
    rows.append(
        [
            "equal-distance check",
            fmt_time(r["check"]),
            "",
            f"max rel. diff {r['max_relative_difference']:.4f}, equal: {r['equal']}",
        ]
    )
    rows.append(
        [
            "route images (`route_image` × 2)",
            fmt_time(r["images"]),
            "",
            ", ".join(f"{b / 1e3:.0f} kB" for b in r["image_bytes"]) + " PNG",
        ]
    )
    skipped = ""
    if "memory" not in res:
        skipped = " The in-memory route was skipped: " + (
            "not enough available memory." if not room_for_memory else "`--no-memory-route`."
        )
    lines = [
        f"# A building-size area: {args.points:,} points, {args.rooms} rooms" + (" (quick)" if args.quick else ""),
        "",
        machine_line(("numpy", "pyarrow", "pandas", "scipy", "networkx", "fairaudit"), memory=True),
        f"Area: `write_building(rooms={args.rooms}, points={args.points})`"
        + ("" if written else f" reused from {args.area}")
        + f"; maps at resolution {args.resolution} m, "
        "robot radius 0.2 m. Each stage runs in its own child process; peak memory is its peak RSS "
        "(`getrusage`), with the interpreter and the imports." + skipped,
        "",
        table(["stage", "time", "peak RSS", "note"], rows, "lrrl"),
        "",
        f"Total benchmark time {total:.1f} s.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="10^6 points over 20 rooms at 0.1 m (seconds)")
    parser.add_argument("--points", type=int, metavar="N", help="points of the area (default 4·10^7)")
    parser.add_argument("--rooms", type=int, metavar="R", help="rooms of the area (default 56)")
    parser.add_argument("--resolution", type=float, metavar="M", help="grid resolution, metres (default 0.05)")
    parser.add_argument("--area", metavar="DIR", help="reuse this area folder (else written to a temporary one)")
    parser.add_argument(
        "--no-memory-route",
        dest="memory_route",
        action="store_false",
        help="do not run build_maps(read_area(...)) for comparison",
    )
    parser.add_argument("--no-profile", dest="profile", action="store_false", help="no cProfile breakdown")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    parser.add_argument("--stage", choices=sorted(STAGES), help=argparse.SUPPRESS)
    parser.add_argument("--work", help=argparse.SUPPRESS)
    parser.add_argument("--profile", dest="child_profile", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    preset = QUICK if args.quick else FULL
    args.points = args.points or preset["points"]
    args.rooms = args.rooms or preset["rooms"]
    args.resolution = args.resolution or preset["resolution"]
    if args.stage:
        _warm()
        out = STAGES[args.stage](args)
        Path(args.work, f"{args.stage}.json").write_text(json.dumps(out))
        return 0
    with tempfile.TemporaryDirectory(prefix="bench_navigation.") as tmp:
        args.work = tmp
        if args.area is None:
            args.area = str(Path(tmp) / "Area_5")
        report, failures = run(args)
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
