//! The solids of the language (docs/language.md) against formulas written here independently:
//! booleans equal raw `min`/`max`, the smooth booleans are C1 and equal `min`/`max` away from
//! the blend, transforms move and turn a surface as a rigid motion (values and gradients),
//! primitives are the distances they claim, and a transformed patch's points are moved.

use crate::common;

use glam::{DQuat, DVec3};
use surfc::sema::program::{Program, SurfaceId, SurfaceRef};
use surfc::surface::Surface;
use surfc::surface::compiled::CompiledSurface;

use common::build::{build, checked};
use common::rng::Rng;

/// The compiled surface called `name` of `program`.
fn surface(program: &Program, name: &str) -> CompiledSurface {
    let id = program
        .surfaces
        .iter()
        .position(|s| s.name == name)
        .unwrap_or_else(|| panic!("no surface {name}"));
    build(program, &SurfaceRef::Surface(SurfaceId(id as u32)), 0.1).expect("compiles")
}

fn random_point(rng: &mut Rng, r: f64) -> DVec3 {
    DVec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r))
}

/// The gradient by central differences.
fn finite_gradient(s: &mut CompiledSurface, p: DVec3, h: f64) -> DVec3 {
    let d =
        |s: &mut CompiledSurface, e: DVec3| (s.value(p + h * e) - s.value(p - h * e)) / (2.0 * h);
    DVec3::new(d(s, DVec3::X), d(s, DVec3::Y), d(s, DVec3::Z))
}

fn sphere_at(p: DVec3, c: DVec3, r: f64) -> f64 {
    (p - c).length() - r
}

#[test]
fn difference_is_max_with_the_negated_others() {
    // Must show 1's solid, written both ways.
    let program = checked(
        "surface named = difference(sphere(1), translate(sphere(0.7), (0.8, 0, 0)));
         surface raw = max(sqrt(x^2 + y^2 + z^2) - 1, -(sqrt((x - 0.8)^2 + y^2 + z^2) - 0.7));
         surface u = union(sphere(1), translate(sphere(0.5), (1, 1, 0)), box((0, 0, 0), (1, 1, 1)));
         surface i = intersection(sphere(1), plane((0, 0, 1), 0.2));",
    );
    let mut named = surface(&program, "named");
    let mut raw = surface(&program, "raw");
    let mut u = surface(&program, "u");
    let mut i = surface(&program, "i");
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let p = random_point(&mut rng, 2.0);
        let (a, b) = (named.value_gradient(p), raw.value_gradient(p));
        assert!(
            (a.value - b.value).abs() <= 1e-12,
            "{p}: {} vs {}",
            a.value,
            b.value
        );
        assert!((a.gradient - b.gradient).length() <= 1e-9, "{p}");
        // union = min of the parts; the box is the six face planes under max.
        let boxed = [-p.x, p.x - 1.0, -p.y, p.y - 1.0, -p.z, p.z - 1.0]
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max);
        let want = sphere_at(p, DVec3::ZERO, 1.0)
            .min(sphere_at(p, DVec3::new(1.0, 1.0, 0.0), 0.5))
            .min(boxed);
        assert!((u.value(p) - want).abs() <= 1e-12, "{p}");
        let want = sphere_at(p, DVec3::ZERO, 1.0).max(p.z - 0.2);
        assert!((i.value(p) - want).abs() <= 1e-12, "{p}");
    }
}

#[test]
fn smooth_booleans_are_c1_and_sharp_far_from_the_blend() {
    let program = checked(
        "const r = 0.3;
         surface a = sphere(1);
         surface b = translate(sphere(0.8), (1.2, 0.3, 0));
         surface su = smooth_union(a, b, r);
         surface si = smooth_intersection(a, b, r);
         surface sd = smooth_difference(a, b, r);",
    );
    let r = 0.3;
    let a = |p: DVec3| sphere_at(p, DVec3::ZERO, 1.0);
    let b = |p: DVec3| sphere_at(p, DVec3::new(1.2, 0.3, 0.0), 0.8);
    for (name, sharp) in [
        ("su", (|x: f64, y: f64| x.min(y)) as fn(f64, f64) -> f64),
        ("si", |x, y| x.max(y)),
        ("sd", |x, y| x.max(-y)),
    ] {
        let mut s = surface(&program, name);
        let mut rng = Rng(11);
        let (mut far, mut blended) = (0, 0);
        for _ in 0..3000 {
            let p = random_point(&mut rng, 2.2);
            let (va, vb) = (a(p), b(p));
            // Which pair of values the blend compares (difference: a and −b).
            let gap = if name == "sd" { va + vb } else { va - vb };
            let vg = s.value_gradient(p);
            if gap.abs() > r * (1.0 + 1e-9) {
                far += 1;
                assert!(
                    (vg.value - sharp(va, vb)).abs() <= 1e-12,
                    "{name} at {p}: {} vs {}",
                    vg.value,
                    sharp(va, vb)
                );
            } else {
                blended += 1;
            }
            // C1 everywhere (the spheres' own kinks at their centres aside).
            if p.length() > 0.05 && (p - DVec3::new(1.2, 0.3, 0.0)).length() > 0.05 {
                let fd = finite_gradient(&mut s, p, 1e-6);
                assert!(
                    (vg.gradient - fd).length() <= 1e-5,
                    "{name} at {p}: gradient {} vs differences {fd}",
                    vg.gradient
                );
            }
        }
        assert!(
            far > 50 && blended > 50,
            "{name}: {far} far, {blended} in the blend"
        );
        // Across the edge of the blend (|gap| = r) the gradient does not jump: walk along the
        // line through both centres and compare the gradients just inside and just outside.
        let dir = DVec3::new(1.2, 0.3, 0.0).normalize();
        let mut t = -1.0;
        let mut prev: Option<(f64, DVec3)> = None;
        while t < 2.5 {
            let p = dir * t + DVec3::new(0.0, 0.0, 0.4);
            let gap = if name == "sd" {
                a(p) + b(p)
            } else {
                a(p) - b(p)
            };
            let g = s.value_gradient(p).gradient;
            if let Some((prev_gap, prev_g)) = prev {
                if (prev_gap.abs() - r) * (gap.abs() - r) < 0.0 {
                    assert!(
                        (g - prev_g).length() < 1e-3,
                        "{name}: the gradient jumps at the blend's edge near {p}"
                    );
                }
            }
            prev = Some((gap, g));
            t += 1e-5;
        }
    }
}

#[test]
fn transforms_are_rigid_motions_and_scalings() {
    let program = checked(
        "surface turned = rotate(translate(sphere(1), (2, 0, 0)), axis: (0, 0, 1), angle: pi / 2);
         surface oblique = rotate(translate(box((-1, -0.5, -0.25), (1, 0.5, 0.25)), (0.3, 0, 0)), axis: (1, 2, 3), angle: 0.7);
         surface grown = scale(torus(1, 0.25), 1.5);
         surface squashed = scale(sphere(1), (2, 1, 0.5));
         fn moved(d) = translate(sphere(0.5), (d, 0, 0));
         surface from_fn = moved(1.5);",
    );
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let boxed = |p: DVec3| {
        let d = (p - DVec3::new(0.3, 0.0, 0.0)).abs() - DVec3::new(1.0, 0.5, 0.25);
        d.max_element()
    };
    let torus = |p: DVec3| (DVec3::new(p.x, p.y, 0.0).length() - 1.0).hypot(p.z) - 0.25;
    let mut turned = surface(&program, "turned");
    let mut oblique = surface(&program, "oblique");
    let mut grown = surface(&program, "grown");
    let mut squashed = surface(&program, "squashed");
    let mut from_fn = surface(&program, "from_fn");
    let mut rng = Rng(3);
    for _ in 0..2000 {
        let p = random_point(&mut rng, 3.0);
        let v = turned.value_gradient(p);
        assert!((v.value - sphere_at(p, DVec3::new(0.0, 2.0, 0.0), 1.0)).abs() <= 1e-12);
        let want = (p - DVec3::new(0.0, 2.0, 0.0)).normalize();
        assert!((v.gradient - want).length() <= 1e-9, "{p}");
        assert!(
            (oblique.value(p) - boxed(q.inverse() * p)).abs() <= 1e-12,
            "{p}"
        );
        assert!(
            (grown.value(p) - 1.5 * torus(p / 1.5)).abs() <= 1e-12,
            "{p}"
        );
        let s = DVec3::new(2.0, 1.0, 0.5);
        assert!((squashed.value(p) - 0.5 * sphere_at(p / s, DVec3::ZERO, 1.0)).abs() <= 1e-12);
        assert!((from_fn.value(p) - sphere_at(p, DVec3::new(1.5, 0.0, 0.0), 0.5)).abs() <= 1e-12);
        // The gradients of the transformed surfaces are right (AD through the transform).
        if boxed(q.inverse() * p).abs() > 1e-3 {
            let fd = finite_gradient(&mut oblique, p, 1e-7);
            let g = oblique.value_gradient(p).gradient;
            // Away from the box's creases (where the active face changes).
            if (g - fd).length() > 1e-5 {
                let probe = 1e-5 * DVec3::ONE;
                let near = (oblique.value_gradient(p + probe).gradient - g).length() > 1e-9
                    || (oblique.value_gradient(p - probe).gradient - g).length() > 1e-9;
                assert!(near, "{p}: gradient {g} vs differences {fd}");
            }
        }
    }
    // The exact quarter turn: (0, 3, 0) is on the surface with the normal along +y.
    let v = turned.value_gradient(DVec3::new(0.0, 3.0, 0.0));
    assert_eq!(v.value, 0.0);
    assert_eq!(v.gradient, DVec3::Y);
}

#[test]
fn primitives_are_their_distances() {
    let program = checked(
        "surface s = sphere(1.5);
         surface b = box((-1, -2, -3), (1, 2, 3));
         surface c = cylinder(1, 2);
         surface t = torus(2, 0.5);
         surface p = plane((1, 1, 0), 0.5);",
    );
    let mut s = surface(&program, "s");
    let mut b = surface(&program, "b");
    let mut c = surface(&program, "c");
    let mut t = surface(&program, "t");
    let mut pl = surface(&program, "p");
    let mut rng = Rng(5);
    for _ in 0..2000 {
        let p = random_point(&mut rng, 4.0);
        assert!((s.value(p) - (p.length() - 1.5)).abs() <= 1e-12);
        // Inside the box the value is minus the distance to the nearest face.
        let half = DVec3::new(1.0, 2.0, 3.0);
        if (p.abs() - half).max_element() < 0.0 {
            let to_face = (half - p.abs()).min_element();
            assert!((b.value(p) + to_face).abs() <= 1e-12, "{p}");
        }
        // Outside, a lower bound of the distance that is exact across each face.
        let outside = (p.abs() - half).max(DVec3::ZERO).length();
        assert!(b.value(p) <= outside + 1e-12, "{p}");
        let radial = p.truncate().length() - 1.0;
        let axial = p.z.abs() - 1.0;
        assert!((c.value(p) - radial.max(axial)).abs() <= 1e-12);
        let ring = (p.truncate().length() - 2.0).hypot(p.z) - 0.5;
        assert!((t.value(p) - ring).abs() <= 1e-12);
        let n = DVec3::new(1.0, 1.0, 0.0).normalize();
        assert!((pl.value(p) - (n.dot(p) - 0.5)).abs() <= 1e-12);
    }
}

#[test]
fn a_transformed_patch_has_moved_points() {
    let program = checked(
        "patch roof(u: 0..1, v: 0..1) = (u, v, u * v);
         surface near_roof = dist(translate(rotate(roof, axis: (0, 0, 1), angle: pi / 2), (0, 0, 1))) - 0.1;",
    );
    // The program holds the transformed patch (both transforms composed) after the declared one.
    assert_eq!(program.patches.len(), 2, "{:?}", program.patches);
    let mut patch =
        surfc::surface::compiled::compile_patch(&program, surfc::sema::program::PatchId(1))
            .expect("compiles");
    use surfc::surface::Patch;
    let mut rng = Rng(9);
    for _ in 0..200 {
        let (u, v) = (rng.unit(), rng.unit());
        let jet = patch.point_jacobian(u, v);
        // Turned a quarter about z, (u, v) → (−v, u), then lifted by 1.
        let want = DVec3::new(-v, u, u * v + 1.0);
        assert!(
            (jet.point - want).length() <= 1e-12,
            "{u}, {v}: {}",
            jet.point
        );
    }
    // The boundary of a transformed patch is that of the new patch.
    let rimmed = checked(
        "patch roof(u: 0..1, v: 0..1) = (u, v, u * v);
         curve rim = boundary(scale(roof, 2));
         surface s = dist(roof);
         mesh m = s { step: 0.1; front: rim; }",
    );
    assert_eq!(
        rimmed.curves[0].kind,
        surfc::sema::program::CurveKind::Boundary(surfc::sema::program::PatchId(1))
    );
    let mut scaled =
        surfc::surface::compiled::compile_patch(&rimmed, surfc::sema::program::PatchId(1))
            .expect("compiles");
    assert!((scaled.point_jacobian(1.0, 1.0).point - DVec3::new(2.0, 2.0, 2.0)).length() <= 1e-12);
    // And dist() of it measures from the moved patch: its point (−0.5, 0.5, 1.25) is on it.
    let mut s = surface(&program, "near_roof");
    let on = DVec3::new(-0.5, 0.5, 1.25);
    assert!((s.value(on) + 0.1).abs() <= 1e-6, "{}", s.value(on));
}

#[test]
fn library_errors_render_into_the_imported_file() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let part = dir.path().join("part.surf");
    std::fs::write(&part, "// a part\nsurface part = spehre(1);\n").expect("write");
    let source = format!("import \"{}\";\nsurface s = part;\n", part.display());
    let errors = surfc::check(&source).expect_err("the part has a typo");
    assert_eq!(errors.diagnostics[0].code, "E0101");
    let text = errors.render("main.surf");
    assert!(text.contains("part.surf:2:16"), "{text}");
    assert!(text.contains("did you mean `sphere`?"), "{text}");
}

/// Nested smooth booleans and nested turns of a patch cost in proportion to their depth: the
/// smooth minimum is one shared function and a patch's transforms are composed into one map
/// (written out, each level would copy its operands two or three times).
#[test]
fn nested_solids_stay_small() {
    let mut solid = "sphere(1)".to_string();
    let mut turned = "roof".to_string();
    for k in 0..40 {
        solid = format!("smooth_union({solid}, translate(sphere(0.5), ({k}, 0, 0)), 0.1)");
        turned = format!("rotate({turned}, axis: (1, 2, 3), angle: 0.1)");
    }
    let source = format!(
        "patch roof(u: 0..1, v: 0..1) = (u, v, u * v);\nsurface s = {solid};\nsurface d = dist({turned}) - 0.1;\n"
    );
    let started = std::time::Instant::now();
    let program = checked(&source);
    let mut s = surface(&program, "s");
    let mut d = surface(&program, "d");
    assert!(s.value(DVec3::new(0.3, 0.2, 0.1)).is_finite());
    assert!(d.value(DVec3::new(0.3, 0.2, 0.1)).is_finite());
    assert!(
        started.elapsed().as_secs_f64() < 5.0,
        "{:?}",
        started.elapsed()
    );
    // 40 unions of 41 spheres: a few operations each, not 3^40.
    let n = s.tape().instrs().len();
    assert!(n < 2000, "{n} instructions");
}

/// `min` and `max` take any number of operands from two: the values of the folded calls
/// against the same formulas computed here, and `fmt` keeps the calls as written.
#[test]
fn min_and_max_take_two_or_more_operands() {
    let text = "surface big = max(x - 1, -x - 1, y - 2, z^2 - 3);\n\
                surface small = min(x, y, z, 2 - x, 5);\n";
    let program = checked(text);
    let mut big = surface(&program, "big");
    let mut small = surface(&program, "small");
    let mut rng = Rng(11);
    for _ in 0..500 {
        let p = random_point(&mut rng, 3.0);
        let want = [p.x - 1.0, -p.x - 1.0, p.y - 2.0, p.z * p.z - 3.0]
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(big.value(p), want, "{p}");
        let want = [p.x, p.y, p.z, 2.0 - p.x, 5.0]
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        assert_eq!(small.value(p), want, "{p}");
    }
    let (file, diags) = surfc::syntax::parse(text);
    assert!(diags.is_empty(), "{diags:?}");
    assert_eq!(surfc::syntax::format(&file.expect("parses")), text);
}
