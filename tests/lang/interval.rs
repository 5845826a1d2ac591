//! Interval soundness (issue 11, must show 4): the interval of every opcode contains every
//! value the opcode takes on dense samples of its operand intervals (random intervals, with
//! the edge values 0, ±∞, ±1, poles and crests, tiny widths), and the interval bound of every
//! gallery surface over 10 000 random boxes contains its value at sampled points of each box.

use crate::common;

use common::build::{build, checked};
use common::rng::Rng;
use glam::DVec3;
use surfc::compile::tape::{Arity, Op};
use surfc::eval::Interval;
use surfc::eval::interval::interval;
use surfc::eval::ops;
use surfc::surface::Surface;

/// Values an interval end is drawn from: the edges where rules switch, and random ones.
fn end(rng: &mut Rng) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let edges = [
        0.0,
        1.0,
        -1.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        FRAC_PI_2,
        -FRAC_PI_2,
        PI,
        -PI,
        2.0,
        0.5,
        1e-300,
        700.0,
        -745.0,
    ];
    match rng.next() % 4 {
        0 => rng.pick(&edges),
        1 => (rng.unit() - 0.5) * 4.0,
        2 => (rng.unit() - 0.5) * 40.0,
        _ => (rng.unit() - 0.5) * 1e6,
    }
}

/// A random interval: two ends, or a tiny one around an end, or a point.
fn random_interval(rng: &mut Rng) -> Interval {
    let a = end(rng);
    match rng.next() % 5 {
        0 => Interval { lo: a, hi: a },
        1 if a.is_finite() => {
            let w = a.abs().max(1.0) * 1e-12;
            Interval { lo: a, hi: a + w }
        }
        _ => {
            let b = end(rng);
            Interval {
                lo: a.min(b),
                hi: a.max(b),
            }
        }
    }
}

/// Dense samples of an interval: its ends (a lower end 0 as +0, an upper end 0 as −0, the
/// convention of `eval::interval`), and points spread over it (over an infinite end, large
/// values up to f64::MAX).
fn samples(i: Interval, rng: &mut Rng, n: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(n + 2);
    let lo = if i.lo == 0.0 { 0.0 } else { i.lo };
    let hi = if i.hi == 0.0 { -0.0 } else { i.hi };
    out.push(lo);
    out.push(hi);
    let big = [1.0, 1e3, 1e30, 1e300, f64::MAX];
    let (flo, fhi) = (
        if lo.is_finite() { lo } else { -rng.pick(&big) },
        if hi.is_finite() { hi } else { rng.pick(&big) },
    );
    for _ in 0..n {
        let v = if flo <= fhi {
            let t = rng.unit();
            // flo + t·(fhi − flo) may overflow for ends near ±MAX: mix instead.
            (flo * (1.0 - t) + fhi * t).clamp(flo, fhi)
        } else {
            flo
        };
        out.push(if lo.is_infinite() && rng.next() % 4 == 0 {
            -rng.pick(&big)
        } else if hi.is_infinite() && rng.next() % 4 == 0 {
            rng.pick(&big)
        } else {
            v
        });
    }
    // Infinite ends are taken too where the operand can be infinite.
    out.retain(|&v| i.lo <= v && v <= i.hi);
    out
}

#[test]
fn every_opcode_contains_its_sampled_values() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let cases_per_op = 4000;
    for op in Op::ALL {
        if op == Op::Dist {
            continue;
        }
        let binary = op.arity() == Arity::Binary;
        let mut checked_values = 0usize;
        for case in 0..cases_per_op {
            let a = random_interval(&mut rng);
            let b = if binary {
                random_interval(&mut rng)
            } else {
                Interval::point(0.0)
            };
            let r = interval(op, a, b);
            let xs = samples(a, &mut rng, 24);
            let ys = if binary {
                samples(b, &mut rng, 24)
            } else {
                vec![0.0]
            };
            for &x in &xs {
                for &y in &ys {
                    let v = ops::value(op, x, y);
                    if v.is_nan() {
                        continue;
                    }
                    checked_values += 1;
                    assert!(
                        r.contains(v),
                        "{} case {case}: {}({x:e}, {y:e}) = {v:e} is outside {r:?} (operands {a:?}, {b:?})",
                        op.name(),
                        op.name()
                    );
                }
            }
        }
        assert!(
            checked_values > 1000,
            "{}: too few defined values",
            op.name()
        );
    }
}

#[test]
fn nan_only_operands_give_empty_intervals_and_zero_divisors_half_lines() {
    let e = Interval::EMPTY;
    assert!(interval(Op::Sqrt, Interval::new(-4.0, -1.0), e).is_empty());
    assert!(interval(Op::Ln, Interval::new(-4.0, -1.0), e).is_empty());
    assert!(interval(Op::Add, e, Interval::point(1.0)).is_empty());
    let r = interval(Op::Recip, Interval::new(0.0, 2.0), e);
    assert!(r.lo <= 0.5 && r.lo > 0.49 && r.hi == f64::INFINITY, "{r:?}");
    let r = interval(Op::Div, Interval::point(1.0), Interval::new(-1.0, 1.0));
    assert_eq!(r, Interval::ENTIRE);
    let r = interval(Op::Sqrt, Interval::new(-1.0, 4.0), e);
    assert!(r.lo == 0.0 && r.hi >= 2.0 && r.hi < 2.0 + 1e-12, "{r:?}");
}

/// Every surface a gallery mesh block meshes, with its box (or a box around the model).
fn gallery_surfaces() -> Vec<(
    String,
    surfc::surface::compiled::CompiledSurface,
    DVec3,
    DVec3,
)> {
    let mut out = Vec::new();
    let mut paths: Vec<_> = std::fs::read_dir("examples")
        .expect("examples/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "surf"))
        .collect();
    paths.sort();
    for path in paths {
        let source = std::fs::read_to_string(&path).expect("readable");
        let program = checked(&source);
        for def in &program.meshes {
            let surface = build(&program, &def.surface, def.step).expect("compiles");
            let (lo, hi) = def.bbox.unwrap_or((DVec3::splat(-7.0), DVec3::splat(7.0)));
            out.push((format!("{}:{}", path.display(), def.name), surface, lo, hi));
        }
    }
    out
}

/// A random box inside `lo .. hi`, its size from the whole down to 10^−`decades` of it.
fn random_cell(rng: &mut Rng, lo: DVec3, hi: DVec3, decades: f64) -> (DVec3, DVec3) {
    let size = hi - lo;
    let scale = 10f64.powf(-decades * rng.unit());
    let w = size * scale * DVec3::new(rng.unit(), rng.unit(), rng.unit()).max(DVec3::splat(0.1));
    let c = lo + (size - w) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
    (c, c + w)
}

/// The random boxes each gallery surface is bounded over: `INTERVAL_BOXES`, by default 4000
/// (`.ci/run` runs 10 000; the partials' test a quarter of that).
fn interval_boxes() -> usize {
    crate::common::env_number("INTERVAL_BOXES").unwrap_or(4_000)
}

#[test]
fn every_gallery_surface_is_bounded_over_random_boxes() {
    let boxes: usize = interval_boxes();
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for (name, mut surface, lo, hi) in gallery_surfaces() {
        let dist = surface.tape().children() > 0;
        // Foot-point searches are slow: fewer samples a box where dist() is involved.
        let interior = if dist { 1 } else { 8 };
        let (mut pruned, mut values) = (0usize, 0usize);
        for b in 0..boxes {
            // Cell sizes from the whole box down to 1e-6 of it, as the octree makes them.
            let (clo, chi) = random_cell(&mut rng, lo, hi, 6.0);
            let w = chi - clo;
            let i = surface
                .bound(clo, chi)
                .expect("a compiled surface bounds itself");
            if !i.contains(0.0) {
                pruned += 1;
            }
            let corners = (0..8).map(|k| {
                DVec3::new(
                    if k & 1 == 0 { clo.x } else { chi.x },
                    if k & 2 == 0 { clo.y } else { chi.y },
                    if k & 4 == 0 { clo.z } else { chi.z },
                )
            });
            let inner: Vec<DVec3> = (0..interior)
                .map(|_| clo + w * DVec3::new(rng.unit(), rng.unit(), rng.unit()))
                .collect();
            let points: Vec<DVec3> = if dist {
                // The centre and one corner (the furthest point of a 1-Lipschitz bound).
                [(clo + chi) * 0.5, chi].into_iter().chain(inner).collect()
            } else {
                corners.chain([(clo + chi) * 0.5]).chain(inner).collect()
            };
            for p in points {
                let v = surface.value(p);
                if v.is_nan() {
                    continue;
                }
                values += 1;
                assert!(
                    i.contains(v),
                    "{name}, box {b} {clo} .. {chi}: f({p}) = {v:e} is outside {i:?}"
                );
            }
        }
        println!("{name}: {boxes} boxes, {values} values inside, {pruned} boxes pruned");
        assert!(values >= boxes, "{name}: too few defined values");
    }
}

/// Interval gradients (issue 11, item 5: the component search prunes with them): for every
/// opcode, on random operand intervals, the partials contain the derivative the dual
/// numbers of `eval::ops` give at every sampled point (x the first operand, y the second).
#[test]
fn every_opcode_contains_its_sampled_derivatives() {
    use surfc::eval::IntervalGrad;
    use surfc::eval::interval_grad::interval_grad;
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    for op in Op::ALL {
        if op == Op::Dist {
            continue;
        }
        let binary = op.arity() == Arity::Binary;
        let mut checked_derivatives = 0usize;
        for case in 0..2000 {
            let a = random_interval(&mut rng);
            let b = if binary {
                random_interval(&mut rng)
            } else {
                Interval::point(0.0)
            };
            let r = interval_grad(op, IntervalGrad::input(a, 0), IntervalGrad::input(b, 1));
            let xs = samples(a, &mut rng, 12);
            let ys = if binary {
                samples(b, &mut rng, 12)
            } else {
                vec![0.0]
            };
            for &x in &xs {
                for &y in &ys {
                    let g = ops::grad(op, ops::Grad::input(x, 0), ops::Grad::input(y, 1));
                    if g.v.is_nan() {
                        continue;
                    }
                    for (k, d) in [g.dx, g.dy].into_iter().enumerate() {
                        if d.is_nan() {
                            continue;
                        }
                        checked_derivatives += 1;
                        assert!(
                            r.d[k].is_empty() || r.d[k].contains(d),
                            "{} case {case}: ∂{k} at ({x:e}, {y:e}) = {d:e} is outside {:?} (operands {a:?}, {b:?})",
                            op.name(),
                            r.d[k]
                        );
                    }
                    assert_eq!(
                        r.d[2],
                        Interval { lo: 0.0, hi: 0.0 },
                        "no z in the operands"
                    );
                }
            }
        }
        assert!(
            checked_derivatives > 1000,
            "{}: too few defined derivatives",
            op.name()
        );
    }
}

/// Every gallery surface over random boxes: the interval partials contain ∇f at sampled
/// points, and where f is defined on the whole box the mean-value form contains f there.
#[test]
fn every_gallery_surface_bounds_its_gradient_over_random_boxes() {
    let boxes: usize = interval_boxes() / 4;
    let mut rng = Rng(0x94D0_49BB_1331_11EB);
    for (name, mut surface, lo, hi) in gallery_surfaces() {
        let dist = surface.tape().children() > 0;
        let interior = if dist { 1 } else { 6 };
        let mut checked_values = 0usize;
        for b in 0..boxes {
            let (clo, chi) = random_cell(&mut rng, lo, hi, 5.0);
            let w = chi - clo;
            let g = surface
                .bound_gradient(clo, chi, [true; 3])
                .expect("a compiled surface bounds its gradient");
            let centre = (clo + chi) * 0.5;
            let at_centre = surface.bound(centre, centre).expect("bounded");
            let mean = g.mean_value(at_centre, clo, chi, [true; 3]);
            for _ in 0..interior {
                let p = clo + w * DVec3::new(rng.unit(), rng.unit(), rng.unit());
                let vg = surface.value_gradient(p);
                if vg.value.is_nan() {
                    continue;
                }
                checked_values += 1;
                assert!(
                    mean.contains(vg.value),
                    "{name}, box {b} {clo} .. {chi}: f({p}) = {:e} is outside the mean-value form {mean:?}",
                    vg.value
                );
                for k in 0..3 {
                    let d = vg.gradient[k];
                    assert!(
                        d.is_nan() || g.d[k].is_empty() || g.d[k].contains(d),
                        "{name}, box {b} {clo} .. {chi}: ∂{k}f({p}) = {d:e} is outside {:?}",
                        g.d[k]
                    );
                }
            }
        }
        println!("{name}: {boxes} boxes, {checked_values} points inside");
    }
}
