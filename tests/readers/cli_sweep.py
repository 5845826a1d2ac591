"""Random shapes through the binary, checked by an independent reader.

Usage: python3 cli_sweep.py SURFC N SEED [DIR]

Writes N `.surf` files (DIR, default ./cli_sweep_SEED) of shapes whose topology, extent and,
where known, volume follow from their construction: tori (`torus`, turned and moved), two
spheres apart (`union`, meshed in a box: two components), superquadrics (x/a)^4 + … = 1
(turned), dumbbells (two spheres and a cylinder joined by `smooth_union`), and tori and
superquadrics at steps that make 250–600 k triangles (which `surfc mesh` cuts into slabs),
thin rings (tube 0.5–3 % of the radius) and thin plates (0.01–0.04 thick) at such steps.
The step is drawn from a quarter of the smallest feature to four times it. Each file is
meshed by `SURFC mesh FILE -o FILE.obj`, and the OBJ read back by trimesh (numpy, trimesh):
watertight, consistently wound, the Euler characteristic and the number of components of the
construction, the extent within the chord tolerance (0.1 step) of the exact one (support
functions), the volume within 0.1 step times the area. A refusal (a non-zero exit with a
diagnostic) counts as refused, never as wrong. Prints one line a shape and the tally; exits
with 1 if any mesh is wrong. With SURFC_SWEEP_RATIO=R in the environment every block also
says `radius_ratio: R;` (the quality stage's aim; the shapes and steps drawn are the same).
"""
import math, os, random, subprocess, sys
import numpy as np, trimesh

BIN = sys.argv[1]; N = int(sys.argv[2]); SEED = int(sys.argv[3])
rng = random.Random(SEED)
D = sys.argv[4] if len(sys.argv) > 4 else "cli_sweep_%d" % SEED
os.makedirs(D, exist_ok=True)

def rot_matrix(axis, angle):
    a = np.array(axis, float); a /= np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K

def rand_axis():
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        n = math.sqrt(sum(x * x for x in v))
        if 0.1 < n <= 1: return [x / n for x in v]

def fmt(v): return "(%r, %r, %r)" % tuple(float(x) for x in v)

def torus(thin=False):
    R = rng.uniform(0.5, 1.5)
    r = R * math.exp(rng.uniform(math.log(0.005), math.log(0.03)) if thin else rng.uniform(math.log(0.04), math.log(0.45)))
    ax = rand_axis(); ang = rng.uniform(0, 6.28); t = [rng.uniform(-1, 1) for _ in range(3)]
    M = rot_matrix(ax, ang)
    # the exact extent: a circle's support plus the tube, R·|e − (e·n)n| + r
    n = M @ np.array([0, 0, 1.0])
    h = np.array([R * math.sqrt(max(0.0, 1 - (e @ n) ** 2)) + r for e in np.eye(3)])
    start = (M @ np.array([R + r, 0, 0])) + t
    src = "surface s = translate(rotate(torus(%r, %r), axis: %s, angle: %r), %s);\n" % (R, r, fmt(ax), ang, fmt(t))
    return dict(area=4 * math.pi ** 2 * R * r, name="torus R=%.3f r=%.3f" % (R, r), src=src, start=start, feature=2 * r, euler=0, comps=1,
                volume=2 * math.pi ** 2 * R * r * r, lo=t - h, hi=t + h, box=None)

def two_spheres():
    r1 = rng.uniform(0.3, 1.0); r2 = rng.uniform(0.3, 1.0); gap = rng.uniform(0.03, 0.5)
    ax = np.array(rand_axis()); c2 = ax * (r1 + r2 + gap)
    src = "surface s = union(sphere(%r), translate(sphere(%r), %s));\n" % (r1, r2, fmt(c2))
    lo = np.minimum(-np.full(3, r1), c2 - r2); hi = np.maximum(np.full(3, r1), c2 + r2)
    return dict(name="two spheres %.3f %.3f gap %.3f" % (r1, r2, gap), src=src, start=None, feature=min(gap, 2 * min(r1, r2)),
                euler=4, comps=2, volume=4 / 3 * math.pi * (r1 ** 3 + r2 ** 3), lo=lo, hi=hi, box=(lo - 0.3, hi + 0.3))

def superquadric(thin=False):
    a = [math.exp(rng.uniform(math.log(0.05), math.log(1.0))) for _ in range(3)]
    if thin:
        # a plate: one semi-axis 0.005–0.02, the others 0.3–0.8
        a = [rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.8), rng.uniform(0.005, 0.02)]
        rng.shuffle(a)
    ax = rand_axis(); ang = rng.uniform(0, 6.28); M = rot_matrix(ax, ang)
    # A draw the first version sampled the surface with: kept, so that a seed draws the
    # shapes it drew then.
    rng.randrange(1 << 30)
    # the exact extent: the support function of the L4 ball (Hölder), (Σ|a_i u_i|^(4/3))^(3/4)
    h = np.array([np.sum(np.abs(np.array(a) * (M.T @ e)) ** (4 / 3)) ** 0.75 for e in np.eye(3)])
    src = "surface s = rotate((x / %r)^4 + (y / %r)^4 + (z / %r)^4 - 1, axis: %s, angle: %r);\n" % (a[0], a[1], a[2], fmt(ax), ang)
    start = M @ np.array([a[0], 0, 0])
    return dict(name="superquadric %.3f×%.3f×%.3f" % tuple(a), src=src, start=start, feature=2 * min(a), euler=2, comps=1,
                volume=None, lo=-h, hi=h, box=None)

def dumbbell():
    a = rng.uniform(0.3, 0.8); d = a + rng.uniform(0.2, 1.0); rn = a * rng.uniform(0.08, 0.6); k = 0.5 * rn
    src = ("surface s = smooth_union(smooth_union(translate(sphere(%r), (%r, 0, 0)), translate(sphere(%r), (%r, 0, 0)), %r), "
           "rotate(cylinder(%r, %r), axis: (0, 1, 0), angle: pi / 2), %r);\n") % (a, -d, a, d, k, rn, 2 * d, k)
    return dict(name="dumbbell a=%.3f d=%.3f neck=%.3f" % (a, d, rn), src=src, start=np.array([d + a, 0, 0]), feature=2 * rn,
                euler=2, comps=1, volume=None, lo=np.array([-d - a, -a, -a]), hi=np.array([d + a, a, a]), box=None, loose=True)

def fine(base, thin=False):
    def make():
        sh = base(thin) if thin else base()
        sh["fine"] = True
        return sh
    return make

fams = [torus, two_spheres, superquadric, dumbbell, fine(torus), fine(superquadric),
        fine(torus, thin=True), fine(superquadric, thin=True)]
tally = dict(right=0, refused=0, wrong=0)
for i in range(N):
    sh = fams[i % len(fams)]()
    step = sh["feature"] * math.exp(rng.uniform(math.log(0.25), math.log(4.0)))
    if sh.get("fine"):
        # a mesh of 250 k to 600 k triangles: `surfc mesh` cuts it into slabs
        # the torus's area, else that of the box around the shape (a superquadric's is less)
        ext = sh["hi"] - sh["lo"]
        area = sh.get("area") or 2 * (ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2])
        want = rng.uniform(250e3, 600e3)
        step = math.sqrt(area / (want * math.sqrt(3) / 4))
    step = float("%.4g" % step)
    opts = "step: %r;" % step
    if os.environ.get("SURFC_SWEEP_RATIO"):
        opts += " radius_ratio: %s;" % os.environ["SURFC_SWEEP_RATIO"]
    if sh["box"] is not None:
        opts += " box: %s .. %s;" % (fmt(sh["box"][0]), fmt(sh["box"][1]))
    else:
        opts += " start: %s;" % fmt(sh["start"])
    src = sh["src"] + "mesh m = s { %s }\n" % opts
    f = os.path.join(D, "c%03d.surf" % i); o = os.path.join(D, "c%03d.obj" % i)
    open(f, "w").write(src)
    if os.path.exists(o): os.remove(o)
    p = subprocess.run([BIN, "mesh", f, "-o", o, "-q"], capture_output=True, text=True, timeout=600)
    what = "#%d %s step %g" % (i, sh["name"], step)
    if p.returncode != 0:
        tally["refused"] += 1
        print(what, "refused:", (p.stderr.strip().splitlines() or ["?"])[0][:150]); continue
    m = trimesh.load(o, process=False, force="mesh")
    m.merge_vertices()
    bad = []
    if not m.is_watertight: bad.append("not watertight")
    if not m.is_winding_consistent: bad.append("winding")
    if m.euler_number != sh["euler"]: bad.append("euler %d want %d" % (m.euler_number, sh["euler"]))
    nc = len(m.split(only_watertight=False))
    if nc != sh["comps"]: bad.append("components %d want %d" % (nc, sh["comps"]))
    tol = 0.1 * step + (0.05 * step if sh.get("loose") else 0) + 1e-9
    off = max(np.abs(m.bounds[0] - sh["lo"]).max(), np.abs(m.bounds[1] - sh["hi"]).max())
    if sh.get("loose"):
        # smoothing may add material only in the blends, inside the box of the spheres' extremes
        off = max(np.abs(m.bounds[0][0] - sh["lo"][0]), np.abs(m.bounds[1][0] - sh["hi"][0]))
    if off > tol: bad.append("box off by %.3g (tol %.3g)" % (off, tol))
    if sh["volume"] is not None:
        # chord error ≤ 0.1 step over the area bounds the volume's error
        if abs(m.volume - sh["volume"]) > 0.1 * step * m.area + 1e-9: bad.append("volume %.4g want %.4g" % (m.volume, sh["volume"]))
    if bad:
        tally["wrong"] += 1; print(what, "WRONG:", ", ".join(bad))
    else:
        tally["right"] += 1; print(what, "right: %d faces" % len(m.faces))
print("CLI sweep seed %d: %s" % (SEED, tally))
sys.exit(1 if tally["wrong"] else 0)
