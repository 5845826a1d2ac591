//! The listings of the gallery's formulas (insta snapshots, source and tape together), and the
//! property that hash-consing leaves no subexpression computed twice.

use crate::common::sources as common;

use std::collections::HashMap;

use common::{program, surface_id};
use surfc::compile::tape::{Arity, Op, Tape};
use surfc::compile::{listing, lower_surface};
use surfc::sema::program::SurfaceRef;

fn lowered(source: &str, name: &str) -> (String, Tape) {
    let p = program(source);
    let l = lower_surface(&p, &SurfaceRef::Surface(surface_id(&p, name))).unwrap();
    (listing(&p, &l), l.tape)
}

/// Value numbering over the tape: an instruction's value is (op, value of a, value of b),
/// where a register's value is the last instruction (or input/constant) that wrote it. Two
/// instructions with the same key compute the same thing.
fn assert_no_recomputation(tape: &Tape) {
    let mut current: Vec<usize> = (0..tape.registers()).collect();
    let mut seen: HashMap<(Op, usize, usize), usize> = HashMap::new();
    for (i, ins) in tape.instrs().iter().enumerate() {
        let key = match ins.op.arity() {
            Arity::Child => (ins.op, usize::from(ins.a.0), 0),
            Arity::Unary => (ins.op, current[ins.a.index()], 0),
            Arity::Binary => (ins.op, current[ins.a.index()], current[ins.b.index()]),
        };
        if let Some(j) = seen.insert(key, i) {
            panic!("instructions {j} and {i} compute the same value:\n{tape}");
        }
        current[ins.out.index()] = tape.registers() + i;
    }
    // And no constant twice.
    let mut constants: Vec<u64> = tape.constants().iter().map(|c| c.to_bits()).collect();
    constants.sort_unstable();
    constants.dedup();
    assert_eq!(constants.len(), tape.constants().len());
}

const SPHERE: &str = include_str!("../../examples/sphere.surf");
const GENUS3: &str = include_str!("../../examples/genus3.surf");
const BLEND: &str = include_str!("../../examples/blend_three_cylinders.surf");

/// The snapshot: which example and surface, the surface's definition, then the listing.
fn snapshot(file: &str, source: &str, name: &str, text: &str) -> String {
    let def: String = source
        .lines()
        .skip_while(|l| !l.starts_with(&format!("surface {name} ")))
        .take_while(|l| !l.is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    format!("examples/{file}, surface {name}:\n{def}\n{text}")
}

#[test]
fn sphere_listing() {
    let (text, tape) = lowered(SPHERE, "sphere");
    assert_no_recomputation(&tape);
    insta::assert_snapshot!(snapshot("sphere.surf", SPHERE, "sphere", &text));
}

#[test]
fn genus3_listing() {
    let (text, tape) = lowered(GENUS3, "genus3");
    assert_no_recomputation(&tape);
    // x², y² and z² once each, though the formula writes y² four times.
    let squares_of_inputs = tape
        .instrs()
        .iter()
        .filter(|i| i.op == Op::Square && i.a.index() < 3)
        .count();
    assert_eq!(squares_of_inputs, 3, "{text}");
    insta::assert_snapshot!(snapshot("genus3.surf", GENUS3, "genus3", &text));
}

#[test]
fn blend_listing() {
    let (text, tape) = lowered(BLEND, "cylinder_blend");
    assert_no_recomputation(&tape);
    insta::assert_snapshot!(snapshot(
        "blend_three_cylinders.surf",
        BLEND,
        "cylinder_blend",
        &text
    ));
}

#[test]
fn repeated_function_calls_are_inlined_once() {
    // 2^20 calls of sq when expanded as a tree; memoised inlining makes it 20 squarings.
    let mut source = String::from("fn sq(t) = t * t;\nfn f0(t) = sq(t);\n");
    for k in 1..=20 {
        source.push_str(&format!(
            "fn f{k}(t) = f{}(t) * f{}(t) + f{}(t);\n",
            k - 1,
            k - 1,
            k - 1
        ));
    }
    source.push_str("surface deep = f20(x) - 1;\n");
    let (text, tape) = lowered(&source, "deep");
    assert_no_recomputation(&tape);
    assert!(tape.instrs().len() <= 3 * 21, "{text}");
}
