#!/usr/bin/env python3
"""surfc beside two peers that make triangles on the same surfaces (docs/speed.md, issue 41).

The gallery's sphere (examples/sphere.surf: x^2 + y^2 + z^2 - 4, step 0.3) and torus
(examples/torus.surf, block `torus`: (x^2 + y^2 + z^2 + r^2 - a^2)^2 - 4 r^2 (x^2 + y^2) with
r = 1, a = 0.35, step 0.1), each meshed by

- surfc (`surfc mesh FILE --threads 1 -o X.obj`, the gallery file itself; `--step` scales it);
- gmsh's frontal-Delaunay 2D algorithm (`Mesh.Algorithm = 6`) on OCC geometry
  (`occ.addSphere(0, 0, 0, 2)`, `occ.addTorus(0, 0, 0, 1, 0.35)`), one uniform mesh size;
- ferreus-rmt's surface-following regularised marching tetrahedra (`build_isosurface`) on the
  same formula evaluated by numpy, seeded at the gallery's start point;

with gmsh's mesh size and ferreus-rmt's resolution corrected (up to three times) until their
mean edge equals surfc's. For each it prints the wall time (median of `--rounds` runs), the
triangles, the mean edge, the smallest angle, the share of triangles whose smallest angle is
below 30 degrees and the mean radius ratio 2 r_in / r_circ, all computed here from the
vertices and triangles each mesher returns, the same way for all.

Everything runs on one thread: surfc `--threads 1`, gmsh `General.NumThreads = 1`,
ferreus-rmt with `RAYON_NUM_THREADS=1`. What is timed: surfc's whole process (parse, compile,
march, verification, report, the OBJ written; the mesh call alone, from its `--json` report,
in brackets); gmsh's `model.mesh.generate(2)` (the OCC model built before the clock starts);
ferreus-rmt's `build_isosurface`, with its Python callbacks.

    python3 -m venv .venv && .venv/bin/pip install numpy gmsh ferreus-rmt
    cargo build --release --bin surfc
    .venv/bin/python benches/peers/peers.py [--surfc target/release/surfc] [--rounds 3]

See benches/peers/README.md.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# ferreus-rmt runs on rayon's pool: one thread, like the others (read when the pool starts).
os.environ.setdefault("RAYON_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

R_MAJOR, R_TUBE = 1.0, 0.35


def sphere_f(p):
    return (p * p).sum(axis=1) - 4.0


def sphere_grad(p):
    return sphere_f(p), 2.0 * p


def torus_f(p):
    s = (p * p).sum(axis=1) + R_MAJOR**2 - R_TUBE**2
    return s * s - 4.0 * R_MAJOR**2 * (p[:, 0] ** 2 + p[:, 1] ** 2)


def torus_grad(p):
    s = (p * p).sum(axis=1) + R_MAJOR**2 - R_TUBE**2
    g = 4.0 * s[:, None] * p
    g[:, 0] -= 8.0 * R_MAJOR**2 * p[:, 0]
    g[:, 1] -= 8.0 * R_MAJOR**2 * p[:, 1]
    return torus_f(p), g


# The gallery's files, the block to mesh, its step as written, the start point (ferreus-rmt's
# seed), the formula with its gradient, and ferreus-rmt's box (the surface well inside).
SURFACES = {
    "sphere": {
        "file": "examples/sphere.surf",
        "block": "sphere",
        "step": 0.3,
        "start": (1.0, 1.0, 1.0),
        "f": sphere_f,
        "grad": sphere_grad,
        "extents": (-2.5, -2.5, -2.5, 2.5, 2.5, 2.5),
    },
    "torus": {
        "file": "examples/torus.surf",
        "block": "torus",
        "step": 0.1,
        "start": (1.0, 0.0, 0.5),
        "f": torus_f,
        "grad": torus_grad,
        "extents": (-1.6, -1.6, -0.6, 1.6, 1.6, 0.6),
    },
}


def shapes(vertices, triangles):
    """Triangles, mean edge (over the triangles' three edges), smallest angle (degrees), share of
    triangles whose smallest angle is below 30 degrees, mean radius ratio
    2 r_in / r_circ = 16 A^2 / (a b c (a + b + c)) (1 for an equilateral triangle)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    p = v[t]
    a = np.linalg.norm(p[:, 1] - p[:, 2], axis=1)
    b = np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    c = np.linalg.norm(p[:, 0] - p[:, 1], axis=1)
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.nan_to_num(16.0 * area**2 / (a * b * c * (a + b + c)), nan=0.0)
        cosines = np.stack(
            [
                (b * b + c * c - a * a) / (2 * b * c),
                (c * c + a * a - b * b) / (2 * c * a),
                (a * a + b * b - c * c) / (2 * a * b),
            ],
            axis=1,
        )
    cosines = np.clip(np.nan_to_num(cosines, nan=1.0), -1.0, 1.0)
    smallest = np.degrees(np.arccos(cosines.max(axis=1)))
    return {
        "triangles": len(t),
        "mean_edge": float(np.concatenate([a, b, c]).mean()),
        "min_angle": float(smallest.min()),
        "below_30": float((smallest < 30.0).mean()),
        "radius_ratio": float(np.minimum(ratio, 1.0).mean()),
    }


def read_obj(path):
    vertices, triangles = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
                triangles.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(vertices), np.array(triangles, dtype=np.int64)


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2]


def surfc_source(name, scale, radius_ratio=None):
    """The gallery file's text, its steps scaled by `scale` (1: as in the gallery), and with
    `radius_ratio: R;` beside the step where `radius_ratio` is given (the quality stage's
    aim; the gallery's default 0.975 where it is not)."""
    s = SURFACES[name]
    text = (ROOT / s["file"]).read_text()
    written = f"step: {s['step']};"
    assert written in text, f"{s['file']} has `{written}`"
    aim = "" if radius_ratio is None else f" radius_ratio: {radius_ratio!r};"
    return text.replace(written, f"step: {s['step'] * scale!r};{aim}")


def run_surfc(binary, name, scale, tmp, radius_ratio=None):
    src = Path(tmp) / f"{name}.surf"
    src.write_text(surfc_source(name, scale, radius_ratio))
    out = Path(tmp) / f"{name}.obj"
    cmd = [binary, "mesh", str(src), "--only", SURFACES[name]["block"], "-o", str(out)]
    cmd += ["--threads", "1", "--json", "-q"]
    t = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if run.returncode != 0:
        sys.exit(f"surfc failed on {name}: {run.stdout}{run.stderr}")
    report = json.loads(run.stdout)
    return seconds, report["meshes"][0]["seconds"], shapes(*read_obj(out))


def run_gmsh(name, size):
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add(name)
        if name == "sphere":
            gmsh.model.occ.addSphere(0, 0, 0, 2.0)
        else:
            gmsh.model.occ.addTorus(0, 0, 0, R_MAJOR, R_TUBE)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # frontal-Delaunay
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        t = time.perf_counter()
        gmsh.model.mesh.generate(2)
        seconds = time.perf_counter() - t
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        _, nodes = gmsh.model.mesh.getElementsByType(2)  # 3-node triangles
        triangles = index[nodes.astype(np.int64)].reshape(-1, 3)
        return seconds, shapes(coords.reshape(-1, 3), triangles)
    finally:
        gmsh.finalize()


def run_ferreus(name, resolution):
    from ferreus_rmt import build_isosurface

    s = SURFACES[name]
    t = time.perf_counter()
    mesh = build_isosurface(
        np.array([s["start"]], dtype=np.float64),
        np.array(s["extents"], dtype=np.float64),
        resolution,
        0.0,
        s["f"],
        gradient_fn=s["grad"],
    )
    seconds = time.perf_counter() - t
    return seconds, shapes(np.asarray(mesh.vertices), np.asarray(mesh.facets))


def calibrated(run, first, target, tries=3):
    """`run` at the parameter (mesh size, resolution) whose mean edge equals `target`: from
    `first`, corrected in proportion up to `tries` times; the parameter and the last result."""
    param = first
    result = run(param)
    for _ in range(tries):
        edge = result[-1]["mean_edge"]
        if abs(edge / target - 1.0) < 2e-3:
            break
        param *= target / edge
        result = run(param)
    return param, result


def main():
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    default = next(
        (p for p in ("target/release/surfc", "target/debug/surfc") if (ROOT / p).exists()),
        "target/release/surfc",
    )
    ap.add_argument("--surfc", default=default, help=f"the surfc binary (default {default})")
    ap.add_argument("--rounds", type=int, default=3, help="timed runs a mesher (median)")
    ap.add_argument(
        "--scale", type=float, default=1.0, help="the gallery's steps times this (default 1)"
    )
    ap.add_argument("--only", choices=sorted(SURFACES), action="append", help="one surface")
    ap.add_argument(
        "--radius-ratio",
        type=float,
        action="append",
        help="also run surfc with this `radius_ratio:` (its quality stage's aim); repeatable",
    )
    ap.add_argument(
        "--calibrate-to-aim",
        action="store_true",
        help="calibrate the peers to the mean edge of surfc's last `--radius-ratio` row "
        "(default: of its default row)",
    )
    args = ap.parse_args()
    binary = str((ROOT / args.surfc) if not os.path.isabs(args.surfc) else args.surfc)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only or ["sphere", "torus"]:
            step = SURFACES[name]["step"] * args.scale
            # surfc at the default aim (its mean edge is what the peers are calibrated to,
            # or the last aim's with `--calibrate-to-aim`), then at each `--radius-ratio`.
            target = None
            for aim in [None, *(args.radius_ratio or [])]:
                runs = [
                    run_surfc(binary, name, args.scale, tmp, aim) for _ in range(args.rounds)
                ]
                seconds = f"{median(r[0] for r in runs):.3f} ({median(r[1] for r in runs):.3f})"
                label = f"surfc, step {step:g}" + ("" if aim is None else f", radius_ratio {aim:g}")
                rows.append((name, label, seconds, runs[0][2]))
                if target is None or args.calibrate_to_aim:
                    target = runs[0][2]["mean_edge"]

            # Each peer at the parameter that gives surfc's mean edge.
            for peer, run, knob in [
                ("gmsh frontal-Delaunay", run_gmsh, "size"),
                ("ferreus-rmt", run_ferreus, "resolution"),
            ]:
                try:
                    value, _ = calibrated(lambda h: run(name, h), step, target)
                    runs = [run(name, value) for _ in range(args.rounds)]
                    seconds = f"{median(r[0] for r in runs):.3f}"
                    rows.append((name, f"{peer}, {knob} {value:.4f}", seconds, runs[0][1]))
                except Exception as e:  # noqa: BLE001 (the table says what failed)
                    rows.append((name, peer, f"failed: {e}", None))

    print(
        "| surface | mesher | wall s | triangles | mean edge | smallest angle "
        "| below 30° | mean radius ratio |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, mesher, seconds, s in rows:
        if s is None:
            print(f"| {name} | {mesher} | {seconds} | | | | | |")
            continue
        print(
            f"| {name} | {mesher} | {seconds} | {s['triangles']} | {s['mean_edge']:.5f} "
            f"| {s['min_angle']:.2f}° | {100 * s['below_30']:.2f} % | {s['radius_ratio']:.4f} |"
        )


if __name__ == "__main__":
    main()
