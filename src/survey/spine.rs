//! The spine of a surface with creases: f written as `min`, `max`, `abs`, negation, sums and
//! constant factors of smooth *branch* surfaces b₀, b₁, … (each evaluated on its own). Every
//! operation of the spine is linear or picks one operand, so wherever the choices are fixed f
//! is a linear *form* Σ cₖ·bₖ + c: the smooth pieces of f are the zero sets of its forms, and a
//! crease is where two forms are both zero and both chosen (docs/creases.md).
//!
//! Built by `compile::spine` from the IR; knows nothing of syntax. Forms are identified by
//! their coefficients, so two patterns of choices that give the same function are one piece.
//!
//! A [`Term::Select`] is a choice made by a *selector* rather than by comparing the operands:
//! the `min`/`max`/`abs` lifted out of a smooth boolean (smin(max(a₁, a₂), b) =
//! max(smin(a₁, b), smin(a₂, b)), exact because smin is monotone) picks its operand by
//! a₁ − a₂, the choice of the original node, since both lifted operands equal b wherever the
//! smooth boolean saturates. The seam between two forms that differ in such a choice is then
//! traced on F = 0 ∩ {selector = 0} ([`Creased::seam`]): transversal in the saturated region
//! too, where it is a seam through smooth surface, and the true crease elsewhere.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use glam::DVec3;

use crate::compile::tape::Op;
use crate::eval::Interval;
use crate::eval::interval::interval;
use crate::mesh::bits::BitsHash;
use crate::surface::{Fault, Surface, ValueGrad};
use crate::values::interval_grad::IntervalGrad;

/// One operation of the spine; operands are earlier terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Term {
    /// Branch surface k.
    Branch(usize),
    Const(f64),
    Neg(usize),
    Add(usize, usize),
    Sub(usize, usize),
    /// c·a.
    Scale(f64, usize),
    Min(usize, usize),
    Max(usize, usize),
    Abs(usize),
    /// `Select(a, b, s)`: a where term s is ≥ 0, else b (a lifted choice, chosen by its
    /// selector s; see the module documentation).
    Select(usize, usize, usize),
}

/// The spine: terms in topological order, the root last.
#[derive(Clone, Debug, PartialEq)]
pub struct Spine {
    terms: Vec<Term>,
    branches: usize,
    /// Terms the root's value depends on (through operands, not selectors): the others are
    /// selectors only, and have no forms of their own to enumerate.
    used: Vec<bool>,
}

/// The choices of the `Select` terms a form was made with: (term, operand a taken).
pub type Picks = Vec<(usize, bool)>;

/// One candidate form of a term: the form, its value at the point, and its picks.
#[derive(Clone, Debug)]
struct Cand {
    form: Form,
    value: f64,
    picks: Picks,
}

/// A linear form Σ cₖ·bₖ + c over the branches: the branches it uses with their
/// coefficients (sorted by branch, none zero) and the constant. Sparse, because a solid of
/// a hundred primitives has hundreds of branches and each form uses one or two of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    pub terms: Vec<(usize, f64)>,
    pub constant: f64,
}

impl Form {
    fn branch(k: usize) -> Form {
        Form {
            terms: vec![(k, 1.0)],
            constant: 0.0,
        }
    }

    fn constant(c: f64) -> Form {
        Form {
            terms: Vec::new(),
            constant: c,
        }
    }

    fn key(&self) -> Vec<u64> {
        let mut key = Vec::new();
        self.key_into(&mut key);
        key
    }

    /// `key` into `key` (cleared first): a lookup's buffer, kept rather than allocated for
    /// each of the many forms looked up.
    fn key_into(&self, key: &mut Vec<u64>) {
        // +0 and −0 are one coefficient.
        key.clear();
        key.extend(
            self.terms
                .iter()
                .flat_map(|&(k, c)| [k as u64, (c + 0.0).to_bits()]),
        );
        key.push((self.constant + 0.0).to_bits());
    }

    /// s·self.
    fn scaled(&self, s: f64) -> Form {
        Form {
            terms: self
                .terms
                .iter()
                .map(|&(k, c)| (k, s * c))
                .filter(|&(_, c)| c != 0.0)
                .collect(),
            constant: s * self.constant,
        }
    }

    /// self + s·other.
    fn plus(&self, s: f64, other: &Form) -> Form {
        let (a, b) = (&self.terms, &other.terms);
        let mut terms = Vec::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() || j < b.len() {
            let next = match (a.get(i), b.get(j)) {
                (Some(&(ka, ca)), Some(&(kb, cb))) if ka == kb => {
                    i += 1;
                    j += 1;
                    (ka, ca + s * cb)
                }
                (Some(&(ka, ca)), Some(&(kb, _))) if ka < kb => {
                    i += 1;
                    (ka, ca)
                }
                (Some(&(ka, ca)), None) => {
                    i += 1;
                    (ka, ca)
                }
                (_, Some(&(kb, cb))) => {
                    j += 1;
                    (kb, s * cb)
                }
                (None, None) => break,
            };
            if next.1 != 0.0 {
                terms.push(next);
            }
        }
        Form {
            terms,
            constant: self.constant + s * other.constant,
        }
    }

    /// The branches the form uses.
    pub fn branches(&self) -> impl Iterator<Item = usize> + '_ {
        self.terms.iter().map(|t| t.0)
    }

    /// The form's value and gradient from its branches' values and gradients.
    pub fn combine(&self, mut branch: impl FnMut(usize) -> ValueGrad) -> ValueGrad {
        let mut out = ValueGrad {
            value: self.constant,
            gradient: DVec3::ZERO,
        };
        for &(k, c) in &self.terms {
            let b = branch(k);
            out.value += c * b.value;
            out.gradient += c * b.gradient;
        }
        out
    }

    /// The form's value from the branches' values.
    pub fn value(&self, branches: &[f64]) -> f64 {
        let mut v = self.constant;
        for &(k, c) in &self.terms {
            v += c * branches[k];
        }
        v
    }

    /// The form's value and partials bounded where each branch k's lie in `bound(k)` (None
    /// when a branch's are unknown).
    pub fn bound_gradient(
        &self,
        mut bound: impl FnMut(usize) -> Option<IntervalGrad>,
    ) -> Option<IntervalGrad> {
        let mut acc = IntervalGrad::constant(Interval::point(self.constant));
        for &(k, c) in &self.terms {
            let g = bound(k)?;
            let c = Interval::point(c);
            let v = interval(Op::Add, acc.v, interval(Op::Mul, g.v, c));
            acc = acc.chain2(g, v, Interval::point(1.0), c);
        }
        Some(acc)
    }

    /// An interval holding the form where each branch k lies in `bound(k)`.
    pub fn bound(&self, mut bound: impl FnMut(usize) -> Interval) -> Interval {
        let mut acc = Interval::point(self.constant);
        for &(k, c) in &self.terms {
            acc = interval(
                Op::Add,
                acc,
                interval(Op::Mul, bound(k), Interval::point(c)),
            );
        }
        acc
    }
}

/// Why a spine cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpineError {
    #[error("term {0} of the spine refers to a later term or a missing branch")]
    Malformed(usize),
    #[error(
        "the surface has more than {0} smooth pieces (choices of its min, max and abs); creases are meshed up to that many"
    )]
    TooManyPieces(usize),
}

/// What a term of a spine stands for once bounds decide its choice (`Spine::pruned`):
/// itself, or an operand it was decided to be (negated for an abs of negative sign).
#[derive(Clone, Copy)]
enum Is {
    Kept,
    Same(usize),
    Negated(usize),
}

impl Spine {
    /// A spine over `branches` branch surfaces; each term may use only earlier terms.
    pub fn new(terms: Vec<Term>, branches: usize) -> Result<Spine, SpineError> {
        for (i, t) in terms.iter().enumerate() {
            let ok = match *t {
                Term::Branch(k) => k < branches,
                Term::Const(_) => true,
                Term::Neg(a) | Term::Scale(_, a) | Term::Abs(a) => a < i,
                Term::Add(a, b) | Term::Sub(a, b) | Term::Min(a, b) | Term::Max(a, b) => {
                    a < i && b < i
                }
                Term::Select(a, b, c) => a < i && b < i && c < i,
            };
            if !ok {
                return Err(SpineError::Malformed(i));
            }
        }
        if terms.is_empty() {
            return Err(SpineError::Malformed(0));
        }
        let mut used = vec![false; terms.len()];
        used[terms.len() - 1] = true;
        for i in (0..terms.len()).rev() {
            if !used[i] {
                continue;
            }
            match terms[i] {
                Term::Branch(_) | Term::Const(_) => {}
                Term::Neg(a) | Term::Scale(_, a) | Term::Abs(a) => used[a] = true,
                Term::Add(a, b)
                | Term::Sub(a, b)
                | Term::Min(a, b)
                | Term::Max(a, b)
                | Term::Select(a, b, _) => {
                    used[a] = true;
                    used[b] = true;
                }
            }
        }
        Ok(Spine {
            terms,
            branches,
            used,
        })
    }

    /// Whether any term chooses (min, max, abs or a selector): else the spine is one form.
    pub fn has_choice(&self) -> bool {
        self.terms.iter().any(|t| {
            matches!(
                t,
                Term::Min(..) | Term::Max(..) | Term::Abs(_) | Term::Select(..)
            )
        })
    }

    /// Whether a term chooses by a selector (the spine lifted a smooth boolean).
    pub fn has_selectors(&self) -> bool {
        self.terms.iter().any(|t| matches!(t, Term::Select(..)))
    }

    pub fn branch_count(&self) -> usize {
        self.branches
    }

    /// f from the branch values and gradients (the gradient of the chosen operands).
    pub fn value_gradient(&self, b: &[ValueGrad]) -> ValueGrad {
        let v = self.term_values(b);
        v[v.len() - 1]
    }

    /// Every term's value and gradient from the branch values and gradients.
    fn term_values(&self, b: &[ValueGrad]) -> Vec<ValueGrad> {
        let mut v = Vec::new();
        self.term_values_with(|k| b[k], &mut v);
        v
    }

    /// `term_values` into `v` (cleared first), with branch k's value and gradient from
    /// `branch(k)`, asked in the order of the spine's terms (a point query evaluates each
    /// branch as the walk reaches it, into no buffer of branch values).
    fn term_values_with(&self, mut branch: impl FnMut(usize) -> ValueGrad, v: &mut Vec<ValueGrad>) {
        v.clear();
        v.reserve(self.terms.len());
        let vg = |value: f64, gradient: DVec3| ValueGrad { value, gradient };
        for t in &self.terms {
            let x = match *t {
                Term::Branch(k) => branch(k),
                Term::Const(c) => vg(c, DVec3::ZERO),
                Term::Neg(a) => vg(-v[a].value, -v[a].gradient),
                Term::Add(a, c) => vg(v[a].value + v[c].value, v[a].gradient + v[c].gradient),
                Term::Sub(a, c) => vg(v[a].value - v[c].value, v[a].gradient - v[c].gradient),
                Term::Scale(s, a) => vg(s * v[a].value, s * v[a].gradient),
                Term::Min(a, c) => {
                    if v[c].value < v[a].value {
                        v[c]
                    } else {
                        v[a]
                    }
                }
                Term::Max(a, c) => {
                    if v[c].value > v[a].value {
                        v[c]
                    } else {
                        v[a]
                    }
                }
                Term::Abs(a) => {
                    if v[a].value < 0.0 {
                        vg(-v[a].value, -v[a].gradient)
                    } else {
                        v[a]
                    }
                }
                Term::Select(a, c, s) => {
                    if v[s].value >= 0.0 {
                        v[a]
                    } else {
                        v[c]
                    }
                }
            };
            v.push(x);
        }
    }

    /// Every form of f (every pattern of choices), each once, in a fixed order; at most
    /// `max` of them.
    pub fn forms(&self, max: usize) -> Result<Vec<Form>, SpineError> {
        Ok(self
            .forms_with_picks(max)?
            .into_iter()
            .map(|f| f.0)
            .collect())
    }

    /// Every form of f, each once, with the picks of every pattern of choices that makes it.
    pub fn forms_with_picks(&self, max: usize) -> Result<Vec<(Form, Vec<Picks>)>, SpineError> {
        let cands = self.candidates(None, max)?;
        let mut seen: HashMap<Vec<u64>, usize> = HashMap::new();
        let mut out: Vec<(Form, Vec<Picks>)> = Vec::new();
        for c in cands {
            match seen.get(&c.form.key()) {
                Some(&k) => out[k].1.push(c.picks),
                None => {
                    seen.insert(c.form.key(), out.len());
                    out.push((c.form, vec![c.picks]));
                }
            }
        }
        Ok(out)
    }

    /// The forms f is made of near the point whose branch values are `values`: every pattern
    /// of choices where each choice is the operand taken or within `eps` of it (a selector
    /// within `eps` of 0). With `None`, every pattern. Each form comes with its value and picks.
    fn candidates(
        &self,
        values: Option<(&[f64], f64)>,
        max: usize,
    ) -> Result<Vec<Cand>, SpineError> {
        let map = |list: &[Cand], s: f64| -> Vec<Cand> {
            list.iter()
                .map(|c| Cand {
                    form: c.form.scaled(s),
                    value: s * c.value,
                    picks: c.picks.clone(),
                })
                .collect()
        };
        let mut terms: Vec<Vec<Cand>> = Vec::with_capacity(self.terms.len());
        let value = |list: &[Cand]| list.first().map_or(f64::NAN, |x| x.value);
        for (index, t) in self.terms.iter().enumerate() {
            // Without values, a term that only selects has no forms to enumerate.
            if values.is_none() && !self.used[index] {
                terms.push(Vec::new());
                continue;
            }
            let list = match *t {
                Term::Branch(k) => vec![Cand {
                    form: Form::branch(k),
                    value: values.map_or(0.0, |(b, _)| b[k]),
                    picks: Vec::new(),
                }],
                Term::Const(c) => vec![Cand {
                    form: Form::constant(c),
                    value: c,
                    picks: Vec::new(),
                }],
                Term::Neg(a) => map(&terms[a], -1.0),
                Term::Scale(s, a) => map(&terms[a], s),
                Term::Add(a, b) | Term::Sub(a, b) => {
                    let s = if matches!(t, Term::Sub(..)) {
                        -1.0
                    } else {
                        1.0
                    };
                    let mut out = Vec::new();
                    for ca in &terms[a] {
                        for cb in &terms[b] {
                            let mut picks = ca.picks.clone();
                            picks.extend_from_slice(&cb.picks);
                            out.push(Cand {
                                form: ca.form.plus(s, &cb.form),
                                value: ca.value + s * cb.value,
                                picks,
                            });
                        }
                    }
                    out
                }
                Term::Min(a, b) | Term::Max(a, b) => {
                    let (va, vb) = (value(&terms[a]), value(&terms[b]));
                    let (take_a, take_b) = match values {
                        None => (true, true),
                        Some((_, eps)) => {
                            let m = if matches!(t, Term::Min(..)) {
                                va.min(vb)
                            } else {
                                va.max(vb)
                            };
                            ((va - m).abs() <= eps, (vb - m).abs() <= eps)
                        }
                    };
                    let mut out = Vec::new();
                    if take_a {
                        out.extend(terms[a].iter().cloned());
                    }
                    if take_b {
                        out.extend(terms[b].iter().cloned());
                    }
                    out
                }
                Term::Select(a, b, sel) => {
                    let (take_a, take_b) = match values {
                        None => (true, true),
                        Some((_, eps)) => {
                            let d = value(&terms[sel]);
                            (d >= -eps, d <= eps)
                        }
                    };
                    let mut out = Vec::new();
                    for (take, from, pick) in [(take_a, a, true), (take_b, b, false)] {
                        if take {
                            out.extend(terms[from].iter().map(|c| {
                                let mut c = c.clone();
                                c.picks.push((index, pick));
                                c
                            }));
                        }
                    }
                    out
                }
                Term::Abs(a) => {
                    let va = value(&terms[a]);
                    let (pos, neg) = match values {
                        None => (true, true),
                        Some((_, eps)) => (va >= -eps, va <= eps),
                    };
                    let mut out = Vec::new();
                    if pos {
                        out.extend(terms[a].iter().cloned());
                    }
                    if neg {
                        out.extend(map(&terms[a], -1.0));
                    }
                    out
                }
            };
            if list.len() > max {
                return Err(SpineError::TooManyPieces(max));
            }
            terms.push(list);
        }
        Ok(terms.pop().unwrap_or_default())
    }

    /// The spine over a region where each branch k takes values in `bound(k)` (outward
    /// rounded; an empty or unknown bound is the whole line): every choice that the bounds
    /// decide is made (a `min` whose one operand lies below the other throughout, an `abs`
    /// of one sign, a selector of one sign), so the result picks among the forms that can be
    /// chosen in the region only — the pruning of Fidget and libfive, which makes the work
    /// near a point depend on the primitives near it. Also returns the bound of f over the
    /// region. Branch ids stay those of `self`; only the branches of the result are bounded.
    pub fn pruned(&self, bound: &mut dyn FnMut(usize) -> Interval) -> (Spine, Interval) {
        self.pruned_if(bound, |_| true)
            .expect("a pruning wanted whatever the bound")
    }

    /// `pruned`, where `wanted` holds for the bound of f over the region; else None, without
    /// building the pruned spine (a search that drops the cells f's bound keeps from zero).
    pub fn pruned_if(
        &self,
        bound: &mut dyn FnMut(usize) -> Interval,
        wanted: impl FnOnce(Interval) -> bool,
    ) -> Option<(Spine, Interval)> {
        let (iv, is) = self.decide(bound);
        let root = iv[iv.len() - 1];
        wanted(root).then(|| (self.emit_decided(&is), root))
    }

    /// The spine of the terms the root reaches once the choices `is` are made (`decide`).
    fn emit_decided(&self, is: &[Is]) -> Spine {
        // The result: the terms the root reaches, each decided choice replaced by the operand
        // it stands for; built from the root down, emitted in topological order.
        let mut new_index: Vec<Option<usize>> = vec![None; self.terms.len()];
        let mut out: Vec<Term> = Vec::new();
        fn emit(
            i: usize,
            terms: &[Term],
            is: &[Is],
            new_index: &mut [Option<usize>],
            out: &mut Vec<Term>,
        ) -> usize {
            if let Some(n) = new_index[i] {
                return n;
            }
            let t = match is[i] {
                Is::Same(a) => {
                    let n = emit(a, terms, is, new_index, out);
                    new_index[i] = Some(n);
                    return n;
                }
                Is::Negated(a) => Term::Neg(emit(a, terms, is, new_index, out)),
                Is::Kept => {
                    let mut e = |j: usize| emit(j, terms, is, new_index, out);
                    match terms[i] {
                        t @ (Term::Branch(_) | Term::Const(_)) => t,
                        Term::Neg(a) => Term::Neg(e(a)),
                        Term::Scale(c, a) => Term::Scale(c, e(a)),
                        Term::Abs(a) => Term::Abs(e(a)),
                        Term::Add(a, b) => {
                            let a = e(a);
                            Term::Add(a, e(b))
                        }
                        Term::Sub(a, b) => {
                            let a = e(a);
                            Term::Sub(a, e(b))
                        }
                        Term::Min(a, b) => {
                            let a = e(a);
                            Term::Min(a, e(b))
                        }
                        Term::Max(a, b) => {
                            let a = e(a);
                            Term::Max(a, e(b))
                        }
                        Term::Select(a, b, s) => {
                            let a = e(a);
                            let b = e(b);
                            Term::Select(a, b, e(s))
                        }
                    }
                }
            };
            out.push(t);
            new_index[i] = Some(out.len() - 1);
            out.len() - 1
        }
        let root = self.terms.len() - 1;
        let top = emit(root, &self.terms, is, &mut new_index, &mut out);
        // The root must be last: a root decided to an earlier term is that term's subtree,
        // which `emit` ends with.
        debug_assert_eq!(top, out.len() - 1);
        Spine::new(out, self.branches).unwrap_or_else(|_| self.clone())
    }

    /// The bound of f where each branch k takes values in `bound(k)`: the interval `pruned`
    /// returns, without building the pruned spine (what a bound alone asks for).
    pub fn bound_over(&self, bound: &mut dyn FnMut(usize) -> Interval) -> Interval {
        let (iv, _) = self.decide(bound);
        iv[iv.len() - 1]
    }

    /// The choices the bounds decide (`pruned`): each term's interval, and what the term
    /// stands for in the result.
    fn decide(&self, bound: &mut dyn FnMut(usize) -> Interval) -> (Vec<Interval>, Vec<Is>) {
        let entire = |i: Interval| if i.is_empty() { Interval::ENTIRE } else { i };
        // Each term's interval, and what it stands for in the result: itself, or an operand
        // it was decided to be (negated for an abs of negative sign).
        let mut iv: Vec<Interval> = Vec::with_capacity(self.terms.len());
        let mut is: Vec<Is> = Vec::with_capacity(self.terms.len());
        for t in &self.terms {
            let (value, what) = match *t {
                Term::Branch(k) => (entire(bound(k)), Is::Kept),
                Term::Const(c) => (Interval::point(c), Is::Kept),
                Term::Neg(a) => (interval(Op::Neg, iv[a], iv[a]), Is::Kept),
                Term::Scale(c, a) => (interval(Op::Mul, iv[a], Interval::point(c)), Is::Kept),
                Term::Add(a, b) => (interval(Op::Add, iv[a], iv[b]), Is::Kept),
                Term::Sub(a, b) => (interval(Op::Sub, iv[a], iv[b]), Is::Kept),
                Term::Min(a, b) | Term::Max(a, b) => {
                    let (x, y) = (iv[a], iv[b]);
                    let min = matches!(t, Term::Min(..));
                    let hull = if min {
                        Interval::new(x.lo.min(y.lo), x.hi.min(y.hi))
                    } else {
                        Interval::new(x.lo.max(y.lo), x.hi.max(y.hi))
                    };
                    // a is always chosen where it lies strictly on the chosen side of b.
                    let (a_wins, b_wins) = if min {
                        (x.hi < y.lo, y.hi < x.lo)
                    } else {
                        (x.lo > y.hi, y.lo > x.hi)
                    };
                    if a_wins {
                        (x, Is::Same(a))
                    } else if b_wins {
                        (y, Is::Same(b))
                    } else {
                        (hull, Is::Kept)
                    }
                }
                Term::Abs(a) => {
                    let x = iv[a];
                    if x.lo >= 0.0 {
                        (x, Is::Same(a))
                    } else if x.hi <= 0.0 {
                        (interval(Op::Neg, x, x), Is::Negated(a))
                    } else {
                        (interval(Op::Abs, x, x), Is::Kept)
                    }
                }
                Term::Select(a, b, sel) => {
                    let s = iv[sel];
                    if s.lo >= 0.0 {
                        (iv[a], Is::Same(a))
                    } else if s.hi < 0.0 {
                        (iv[b], Is::Same(b))
                    } else {
                        (iv[a].hull(iv[b]), Is::Kept)
                    }
                }
            };
            iv.push(value);
            is.push(what);
        }
        (iv, is)
    }

    /// The branches the spine's terms use.
    pub fn branches_used(&self) -> impl Iterator<Item = usize> + '_ {
        self.terms.iter().filter_map(|t| match *t {
            Term::Branch(k) => Some(k),
            _ => None,
        })
    }

    /// How two forms are told apart, from their picks: by one `Select` (its selector term),
    /// preferring a pair of patterns that differ in that choice alone; by plain `min`, `max`
    /// or `abs` only (their seam is where the two forms are equal); or only by two lifted
    /// choices or more, so that they meet at corners, not along a seam.
    fn between(&self, a: &[Picks], b: &[Picks]) -> Between {
        let mut plain = false;
        for pa in a {
            for pb in b {
                let differ: Vec<usize> = pa
                    .iter()
                    .filter(|(t, c)| pb.iter().any(|(u, d)| u == t && d != c))
                    .map(|&(t, _)| t)
                    .collect();
                match differ[..] {
                    [] => plain = true,
                    [t] => {
                        if let Term::Select(_, _, s) = self.terms[t] {
                            return Between::Select(s);
                        }
                    }
                    _ => {}
                }
            }
        }
        if plain {
            Between::Plain
        } else {
            Between::Apart
        }
    }
}

/// How two forms are told apart (`Spine::between`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Between {
    Plain,
    Select(usize),
    Apart,
}

/// A surface with creases: its spine, the branch surfaces, the forms met so far (the smooth
/// pieces), and which of them are one face (coincident sheets).
///
/// A spine that chooses by selectors (a lifted smooth boolean) has its forms enumerated once,
/// with their picks, at most [`MAX_FORMS`]; any other spine registers its forms as the crease
/// search meets them (`Spine::pruned` per cell, `active` at points), in a deterministic
/// order, with no cap: a part of hundreds of faces has hundreds of forms, a few near each
/// place.
pub struct Creased {
    spine: Arc<Spine>,
    branches: Vec<Box<dyn Surface>>,
    forms: Vec<Form>,
    index: HashMap<Vec<u64>, usize>,
    /// How each pair of forms is told apart (both orders; absent: `Between::Plain`).
    seams: HashMap<(usize, usize), Between>,
    /// Whether the forms were enumerated at construction (a spine with selectors).
    enumerated: bool,
    /// Union-find over forms: forms that are one face (the same oriented sheet).
    parent: Vec<usize>,
    /// Pairs of forms (smaller first) never made one face: one sheet on part of the surface
    /// only, with a crease between them elsewhere (`keep_apart`).
    apart: HashSet<(usize, usize)>,
    /// The branches' values and gradients at `at` (the last point asked), as far as asked:
    /// an entry is valid when its generation is `generation`, which a new point advances
    /// (rather than clearing an entry per branch at every point).
    at: Option<[u64; 3]>,
    generation: u64,
    cache: Vec<(u64, ValueGrad)>,
    /// The side of the cells over which the spine is pruned for point queries (`localize`),
    /// and those pruned spines: f and its choices at a point need only the branches that
    /// can be chosen near it. Cells of `LOCAL_LEVELS` sizes are kept, `local_size`·2^level,
    /// each pruned from the spine of the cell one level up that holds it (the whole spine
    /// above the top level), so that a cell's pruning bounds only the few branches its
    /// parent left.
    local_size: Option<f64>,
    local: HashMap<(u32, [i64; 3]), Arc<Spine>, BitsHash>,
    /// Cells of recent point queries with their pruned spines, one place for each parity
    /// of the cell's coordinates: a star's points and a chord's straddle up to eight
    /// neighbouring cells, and neighbours never share a place.
    last_local: [Option<([i64; 3], Arc<Spine>)>; 8],
    /// The buffers of the point queries, reused rather than allocated for each of the
    /// crease net's many points: the branches' values for `active` (`branches_of`), the
    /// terms' for `whole`, and a form's key for the lookups in `index` (`id`, `active`).
    branch_values: Vec<ValueGrad>,
    term_scratch: Vec<ValueGrad>,
    key_scratch: Vec<u64>,
}

/// The most forms (smooth pieces) of a spine that chooses by selectors (a lifted smooth
/// boolean), whose forms are enumerated at once: nested smooth booleans multiply their
/// operands' pieces. Plain spines (min, max, abs) have no cap.
pub const MAX_FORMS: usize = 64;

/// The most forms one octree cell of the crease search may pick among: a pattern explosion
/// (sums of many `abs`), not a solid.
pub const MAX_CELL_FORMS: usize = 4096;

/// How many sizes of cells a `localize`d spine is pruned over: its cells and those 2, 4, …
/// 32 times as wide (128 steps for the crease net's four).
const LOCAL_LEVELS: u32 = 6;

/// A cell's place among the recent ones: the parities of its coordinates.
fn parity(key: [i64; 3]) -> usize {
    (key[0] & 1 | (key[1] & 1) << 1 | (key[2] & 1) << 2) as usize
}

/// Cell coordinates below this (2⁵²) are whole numbers that a key holds exactly; beyond it
/// the spine is not localized.
const EXACT_CELLS: f64 = 4_503_599_627_370_496.0;

impl Creased {
    pub fn new(spine: Spine, branches: Vec<Box<dyn Surface>>) -> Result<Creased, SpineError> {
        if branches.len() != spine.branch_count() {
            return Err(SpineError::Malformed(0));
        }
        let mut forms = Vec::new();
        let mut seams = HashMap::new();
        let enumerated = spine.has_selectors();
        if enumerated {
            let with_picks = spine.forms_with_picks(MAX_FORMS)?;
            for (i, (_, pi)) in with_picks.iter().enumerate() {
                for (j, (_, pj)) in with_picks.iter().enumerate().skip(i + 1) {
                    let b = spine.between(pi, pj);
                    if b != Between::Plain {
                        seams.insert((i, j), b);
                        seams.insert((j, i), b);
                    }
                }
            }
            forms = with_picks.into_iter().map(|f| f.0).collect();
        }
        let index = forms
            .iter()
            .enumerate()
            .map(|(i, f)| (f.key(), i))
            .collect();
        let parent = (0..forms.len()).collect();
        let shape = Shape {
            spine: Arc::new(spine),
            forms,
            index,
            seams,
            enumerated,
            parent,
            apart: HashSet::new(),
            local_size: None,
            local: HashMap::default(),
        };
        Ok(shape.into_creased(branches))
    }

    /// Prunes the spine over cells of side `size` for the point queries that follow (`whole`,
    /// `active`; the crease net takes four steps): exact, since a choice is pruned only where the bounds decide it throughout
    /// the cell. Not for a spine with selectors, whose terms the seams refer to.
    pub fn localize(&mut self, size: f64) {
        if !self.enumerated && size.is_finite() && size > 0.0 {
            self.local_size = Some(size);
            self.local.clear();
            self.last_local = Default::default();
        }
    }

    /// The spine to evaluate at p: pruned over p's cell when `localize`d.
    fn spine_at(&mut self, p: DVec3) -> Arc<Spine> {
        let taken = self.take_spine_at(p);
        let spine = taken.1.clone();
        self.give_back(taken);
        spine
    }

    /// `spine_at`, with p's cell, moved out of `last_local` where it is there (the point
    /// queries' runs in one cell: a Newton solve, a star's points), to be handed back with
    /// `give_back` (rather than a count taken and dropped at every point).
    fn take_spine_at(&mut self, p: DVec3) -> (Option<[i64; 3]>, Arc<Spine>) {
        let Some(size) = self.local_size else {
            return (None, self.spine.clone());
        };
        // By the reciprocal, not a division a coordinate: a point within rounding of a side
        // may land in the cell beside, whose pruning (over the cell and a margin) holds it.
        let cell = p * size.recip();
        // Far out (or NaN), a cell's key would not be exact: the whole spine.
        let exact = cell.abs().max_element() < EXACT_CELLS;
        if !exact {
            return (None, self.spine.clone());
        }
        let key = cell.to_array().map(crate::values::floor);
        let slot = &mut self.last_local[parity(key)];
        if slot.as_ref().is_some_and(|(last, _)| *last == key)
            && let Some((_, s)) = slot.take()
        {
            return (Some(key), s);
        }
        (Some(key), self.local_spine(0, key, size))
    }

    /// Keeps the spine `take_spine_at` gave in its cell's place.
    fn give_back(&mut self, (key, spine): (Option<[i64; 3]>, Arc<Spine>)) {
        if let Some(key) = key {
            self.last_local[parity(key)] = Some((key, spine));
        }
    }

    /// The spine pruned over cell `key` of side `size`·2^level (and a margin, so that a
    /// point on its boundary is well inside), pruned from its parent cell's spine. The same
    /// spine as the whole one pruned over the cell: a choice decided over the parent is
    /// decided the same way over the cell inside it, whose bounds lie in the parent's, and a
    /// decided term's interval is its chosen operand's.
    fn local_spine(&mut self, level: u32, key: [i64; 3], size: f64) -> Arc<Spine> {
        if let Some(s) = self.local.get(&(level, key)) {
            return s.clone();
        }
        let base = if level + 1 < LOCAL_LEVELS {
            self.local_spine(level + 1, key.map(|c| c.div_euclid(2)), 2.0 * size)
        } else {
            self.spine.clone()
        };
        let lo = DVec3::from(key.map(|c| c as f64)) * size - DVec3::splat(0.01 * size);
        let hi = lo + DVec3::splat(1.02 * size);
        let branches = &mut self.branches;
        let (pruned, _) =
            base.pruned(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE));
        let pruned = Arc::new(pruned);
        self.local.insert((level, key), pruned.clone());
        pruned
    }

    /// The spine to prune over the box lo..hi: the pruned spine of the smallest `localize`d
    /// cell that holds the box, or the whole spine.
    fn base_for(&mut self, lo: DVec3, hi: DVec3) -> Arc<Spine> {
        if let Some(size) = self.local_size {
            let mut side = size;
            for level in 0..LOCAL_LEVELS {
                let (a, b) = ((lo / side).floor(), (hi / side).floor());
                if a == b && a.abs().max_element() < EXACT_CELLS {
                    return self.local_spine(level, a.to_array().map(|c| c as i64), side);
                }
                side *= 2.0;
            }
        }
        self.spine.clone()
    }

    /// An interval holding f over the box lo..hi: the spine pruned over it, each branch
    /// bounded by its own tape (whole line where a branch cannot bound itself).
    pub fn bound(&mut self, lo: DVec3, hi: DVec3) -> Interval {
        let base = self.base_for(lo, hi);
        let branches = &mut self.branches;
        base.bound_over(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE))
    }

    /// f's value and partials over the box lo..hi: the value as `bound` says, the partials
    /// the hull of those of the forms that can be chosen in the box (the generalized gradient
    /// of a piecewise f lies in it). None when a branch cannot bound its partials or the box
    /// holds more than `MAX_CELL_FORMS` forms.
    pub fn bound_gradient(
        &mut self,
        lo: DVec3,
        hi: DVec3,
        axes: [bool; 3],
    ) -> Option<IntervalGrad> {
        let mut hull: Option<IntervalGrad> = None;
        let value = self.each_form_gradient(lo, hi, axes, |acc| {
            hull = Some(match hull {
                None => acc,
                Some(o) => IntervalGrad {
                    v: o.v.hull(acc.v),
                    d: std::array::from_fn(|k| o.d[k].hull(acc.d[k])),
                    defined: o.defined && acc.defined,
                },
            });
        })?;
        let mut g = hull?;
        g.v = value;
        Some(g)
    }

    /// Whether an element of f's generalized gradient over the box lo..hi may be orthogonal
    /// to both `across` directions (where a piece of the surface may have its extreme along
    /// the direction orthogonal to them: the inside octree of `survey::cells`). Tighter than
    /// the hull of the partials that `bound_gradient` gives: at a crease the two faces'
    /// gradients span a box holding 0 (two normals along the axes: [0, 1] in two partials),
    /// where the segment between them need not hold a vector orthogonal to both directions.
    /// Each form's derivatives along the two directions bound a rectangle; the generalized
    /// gradient's lie in the convex hull of those rectangles, and the answer is whether the
    /// origin may lie in it. True when it cannot tell.
    pub fn gradient_may_face(&mut self, lo: DVec3, hi: DVec3, across: [DVec3; 2]) -> bool {
        let mut corners = Vec::new();
        let told = self.each_form_gradient(lo, hi, [true; 3], |g| {
            let [a, b] = across.map(|d| g.derivative_along(d));
            corners.extend([(a.lo, b.lo), (a.lo, b.hi), (a.hi, b.lo), (a.hi, b.hi)]);
        });
        told.is_none() || origin_may_be_in_hull(&corners)
    }

    /// Calls `each` with the value and partials (those `axes` asks for) of each form that can
    /// be chosen over the box lo..hi, in order, and gives the value bound there (as `bound`);
    /// None, perhaps after some calls, as for `bound_gradient`.
    fn each_form_gradient(
        &mut self,
        lo: DVec3,
        hi: DVec3,
        axes: [bool; 3],
        mut each: impl FnMut(IntervalGrad),
    ) -> Option<Interval> {
        let base = self.base_for(lo, hi);
        let branches = &mut self.branches;
        let (pruned, value) =
            base.pruned(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE));
        let forms = pruned.candidates(None, MAX_CELL_FORMS).ok()?;
        let mut grads: HashMap<usize, IntervalGrad> = HashMap::new();
        for cand in &forms {
            each(cand.form.bound_gradient(|k| match grads.get(&k) {
                Some(g) => Some(*g),
                None => {
                    let g = branches[k].bound_gradient(lo, hi, axes)?;
                    grads.insert(k, g);
                    Some(g)
                }
            })?);
        }
        Some(value)
    }

    /// The values and gradients of the branches `spine` uses at p, into `branch_values`.
    /// The others hold what an earlier point left there, or NaN: `spine` reads only the
    /// branches it uses.
    fn branches_of(&mut self, spine: &Spine, p: DVec3) {
        self.branch_values.resize(
            self.branches.len(),
            ValueGrad {
                value: f64::NAN,
                gradient: DVec3::NAN,
            },
        );
        for k in spine.branches_used() {
            let v = self.branch_at(k, p);
            self.branch_values[k] = v;
        }
    }

    /// The forms registered so far (all of them for a spine with selectors).
    pub fn form_count(&self) -> usize {
        self.forms.len()
    }

    pub fn spine(&self) -> &Spine {
        &self.spine
    }

    /// Whether the forms were all enumerated at construction (a spine with selectors):
    /// then the crease search bounds every form in each cell instead of pruning the spine.
    pub fn enumerated(&self) -> bool {
        self.enumerated
    }

    /// The id of a form, registered if new.
    fn id(&mut self, form: &Form) -> usize {
        form.key_into(&mut self.key_scratch);
        if let Some(&i) = self.index.get(self.key_scratch.as_slice()) {
            return i;
        }
        let i = self.forms.len();
        self.forms.push(form.clone());
        self.index.insert(self.key_scratch.clone(), i);
        self.parent.push(i);
        i
    }

    /// Branch k's value and gradient at p, evaluated once per point.
    fn branch_at(&mut self, k: usize, p: DVec3) -> ValueGrad {
        let bits = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        if self.at != Some(bits) {
            self.at = Some(bits);
            self.generation += 1;
        }
        let (generation, v) = self.cache[k];
        if generation == self.generation {
            return v;
        }
        let v = self.branches[k].value_gradient(p);
        self.cache[k] = (self.generation, v);
        v
    }

    /// Value and gradient of form i at p (only its own branches are evaluated).
    pub fn form(&mut self, i: usize, p: DVec3) -> ValueGrad {
        let terms = std::mem::take(&mut self.forms[i].terms);
        let out = Form {
            terms,
            constant: self.forms[i].constant,
        };
        let v = out.combine(|k| self.branch_at(k, p));
        self.forms[i].terms = out.terms;
        v
    }

    fn all_branches(&mut self, p: DVec3) -> Vec<ValueGrad> {
        (0..self.branches.len())
            .map(|k| self.branch_at(k, p))
            .collect()
    }

    /// Form i and the function whose zero on it is the seam with form j, at p: form j where
    /// a plain `min`/`max`/`abs` tells them apart (they are equal on the seam), else the
    /// selector of the lifted choice between them (see the module documentation), which
    /// stays transversal where the two forms coincide.
    pub fn seam(&mut self, i: usize, j: usize, p: DVec3) -> (ValueGrad, ValueGrad) {
        let li = self.form(i, p);
        let other = match self.seams.get(&(i, j)) {
            Some(&Between::Select(s)) => {
                let b = self.all_branches(p);
                self.spine.term_values(&b)[s]
            }
            _ => self.form(j, p),
        };
        (li, other)
    }

    /// Whether forms i and j can meet along a seam: not when only two lifted choices or more
    /// tell them apart (they meet at corners only).
    pub fn adjacent(&self, i: usize, j: usize) -> bool {
        self.seams.get(&(i, j)) != Some(&Between::Apart)
    }

    /// Whether forms i and j are told apart by a lifted choice (their seam is a selector's
    /// zero, not where they are equal).
    pub fn by_selector(&self, i: usize, j: usize) -> bool {
        matches!(self.seams.get(&(i, j)), Some(Between::Select(_)))
    }

    /// Value and gradient of f at p, through the spine.
    pub fn whole(&mut self, p: DVec3) -> ValueGrad {
        let taken = self.take_spine_at(p);
        let mut terms = std::mem::take(&mut self.term_scratch);
        taken
            .1
            .term_values_with(|k| self.branch_at(k, p), &mut terms);
        let out = terms[terms.len() - 1];
        self.term_scratch = terms;
        self.give_back(taken);
        out
    }

    /// The forms chosen at p, with every choice within `eps` (function units) of the one
    /// taken counted as a tie: sorted form indices.
    pub fn active(&mut self, p: DVec3, eps: f64) -> Vec<usize> {
        let spine = self.spine_at(p);
        self.branches_of(&spine, p);
        let values: Vec<f64> = self.branch_values.iter().map(|b| b.value).collect();
        let Ok(cands) = spine.candidates(Some((&values, eps)), MAX_CELL_FORMS) else {
            return Vec::new();
        };
        let mut out: Vec<usize> = if self.enumerated {
            let (index, key) = (&self.index, &mut self.key_scratch);
            cands
                .iter()
                .filter_map(|c| {
                    c.form.key_into(key);
                    index.get(key.as_slice()).copied()
                })
                .collect()
        } else {
            cands.iter().map(|c| self.id(&c.form)).collect()
        };
        out.sort_unstable();
        out.dedup();
        out
    }

    /// An interval holding branch k over the box lo..hi (the whole line when the branch
    /// cannot bound itself).
    pub fn branch_bound(&mut self, k: usize, lo: DVec3, hi: DVec3) -> Interval {
        self.branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE)
    }

    /// An interval holding form i over the box lo..hi, from the branches' bounds (None when
    /// a branch cannot bound itself).
    pub fn form_bound(&mut self, i: usize, lo: DVec3, hi: DVec3) -> Option<Interval> {
        bound_on(&self.forms[i], &mut self.branches, lo, hi)
    }

    /// The forms of `spine` (a pruned spine of this surface), registered: every pattern of
    /// its choices. Err when they are more than [`MAX_CELL_FORMS`].
    pub fn forms_of(&mut self, spine: &Spine) -> Result<Vec<usize>, SpineError> {
        let cands = spine.candidates(None, MAX_CELL_FORMS)?;
        let mut out: Vec<usize> = cands.iter().map(|c| self.id(&c.form)).collect();
        out.sort_unstable();
        out.dedup();
        Ok(out)
    }

    /// The forms that can be chosen somewhere in the box lo..hi (every form of a spine with
    /// selectors; else those of the spine pruned over the box), registered.
    pub fn forms_near(&mut self, lo: DVec3, hi: DVec3) -> Result<Vec<usize>, SpineError> {
        if self.enumerated {
            return Ok((0..self.forms.len()).collect());
        }
        let base = self.base_for(lo, hi);
        let branches = &mut self.branches;
        let (pruned, _) =
            base.pruned(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE));
        self.forms_of(&pruned)
    }

    /// Form i's face: the smallest form of its class (forms found to be one oriented sheet).
    pub fn class(&mut self, i: usize) -> usize {
        let mut r = i;
        while self.parent[r] != r {
            r = self.parent[r];
        }
        // Path halving keeps later lookups short.
        let mut k = i;
        while self.parent[k] != r {
            let next = self.parent[k];
            self.parent[k] = r;
            k = next;
        }
        r
    }

    /// Records that forms i and j are one face (unless they are kept apart).
    pub fn unite(&mut self, i: usize, j: usize) {
        if self.apart.contains(&(i.min(j), i.max(j))) {
            return;
        }
        let (a, b) = (self.class(i), self.class(j));
        if a != b {
            // The smaller id stays the root, so a class's face is its first form.
            let (lo, hi) = (a.min(b), a.max(b));
            self.parent[hi] = lo;
        }
    }

    /// Forms i and j are never one face from now on, and every form is its own face again:
    /// they were found one sheet in one place and crossing at an angle in another (the
    /// offsets of two solids flush on a face), so the crease search starts over with them
    /// as two faces that coincide on part of the surface.
    pub fn keep_apart(&mut self, i: usize, j: usize) {
        self.apart.insert((i.min(j), i.max(j)));
        for (k, p) in self.parent.iter_mut().enumerate() {
            *p = k;
        }
    }

    /// The first fault of a branch (a `dist` without a foot point), if any.
    pub fn fault(&self) -> Option<Fault> {
        self.branches.iter().find_map(|b| b.fault())
    }

    /// Form i as a surface of its own.
    pub fn piece(&mut self, i: usize) -> Piece<'_> {
        Piece { of: self, form: i }
    }

    /// Form i, to be evaluated on fresh oracles of the branches ([`Detached`]).
    pub fn form_terms(&self, i: usize) -> Form {
        self.forms[i].clone()
    }

    /// This surface without its oracles, for threads that put it on branches of their own
    /// ([`Shape::on`]).
    pub fn shape(&self) -> Shape {
        Shape {
            spine: Arc::clone(&self.spine),
            forms: self.forms.clone(),
            index: self.index.clone(),
            seams: self.seams.clone(),
            enumerated: self.enumerated,
            parent: self.parent.clone(),
            apart: self.apart.clone(),
            local_size: self.local_size,
            local: self.local.clone(),
        }
    }
}

/// A [`Creased`] without its oracles (its spine, forms, faces and the cells pruned so far),
/// shared by threads that each put it on fresh oracles of the branches (`BranchFork`): a
/// copy answers every point query as the original does (the same branches, the same cells
/// pruned, on demand where not yet); what a copy registers or learns stays in the copy.
#[derive(Clone)]
pub struct Shape {
    spine: Arc<Spine>,
    forms: Vec<Form>,
    index: HashMap<Vec<u64>, usize>,
    seams: HashMap<(usize, usize), Between>,
    enumerated: bool,
    parent: Vec<usize>,
    apart: HashSet<(usize, usize)>,
    local_size: Option<f64>,
    local: HashMap<(u32, [i64; 3]), Arc<Spine>, BitsHash>,
}

impl Shape {
    /// The surface on `branches` (fresh oracles of the spine's branches, in its order); None
    /// when they are not as many.
    pub fn on(&self, branches: Vec<Box<dyn Surface>>) -> Option<Creased> {
        (branches.len() == self.spine.branch_count()).then(|| self.clone().into_creased(branches))
    }

    /// The surface on `branches` (as many as the spine's), its point caches empty.
    fn into_creased(self, branches: Vec<Box<dyn Surface>>) -> Creased {
        let unknown = ValueGrad {
            value: f64::NAN,
            gradient: DVec3::NAN,
        };
        // Generation 0: older than every point's.
        let cache = vec![(0, unknown); branches.len()];
        Creased {
            spine: self.spine,
            branches,
            forms: self.forms,
            index: self.index,
            seams: self.seams,
            enumerated: self.enumerated,
            parent: self.parent,
            apart: self.apart,
            at: None,
            generation: 1,
            cache,
            local_size: self.local_size,
            local: self.local,
            last_local: Default::default(),
            branch_values: Vec::new(),
            term_scratch: Vec::new(),
            key_scratch: Vec::new(),
        }
    }
}

/// [`bound_on`] with the partials the axes ask for.
fn bound_gradient_on(
    form: &Form,
    branches: &mut [Box<dyn Surface>],
    lo: DVec3,
    hi: DVec3,
    axes: [bool; 3],
) -> Option<IntervalGrad> {
    form.bound_gradient(|k| branches[k].bound_gradient(lo, hi, axes))
}

/// An interval holding `form` over the box lo..hi from its branches' bounds (None when a
/// branch cannot bound itself).
fn bound_on(
    form: &Form,
    branches: &mut [Box<dyn Surface>],
    lo: DVec3,
    hi: DVec3,
) -> Option<Interval> {
    let mut known = true;
    let b = form.bound(|k| match branches[k].bound(lo, hi) {
        Some(b) => b,
        None => {
            known = false;
            Interval::ENTIRE
        }
    });
    known.then_some(b)
}

/// One form of a creased surface on branches of its own: fresh oracles of the surface's
/// branches (`surface::BranchFork`), made on the thread that marches the piece. Bit for bit
/// what [`Creased::piece`] gives where the branches answer the same whatever was asked
/// before (all but the warm starts of `dist`).
pub struct Detached {
    form: Form,
    branches: Vec<Box<dyn Surface>>,
    /// A batch's sum and one branch's values (`value_gradient_batch`), kept between batches.
    batch: (Vec<ValueGrad>, Vec<ValueGrad>),
}

impl Detached {
    /// `form` (from [`Creased::form_terms`]) on `branches`; None when a branch it uses is
    /// missing.
    pub fn new(form: Form, branches: Vec<Box<dyn Surface>>) -> Option<Detached> {
        let known = form.branches().all(|k| k < branches.len());
        known.then_some(Detached {
            form,
            branches,
            batch: (Vec::new(), Vec::new()),
        })
    }
}

impl Surface for Detached {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        let branches = &mut self.branches;
        self.form.combine(|k| branches[k].value_gradient(p))
    }

    /// Each branch over the batch, summed in the form's order as `combine` sums them: the
    /// same bits as a point at a time, where every branch answers in batches.
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        let n = points.len().min(out.len());
        let (sum, branch) = &mut self.batch;
        sum.clear();
        sum.resize(
            n,
            ValueGrad {
                value: self.form.constant,
                gradient: DVec3::ZERO,
            },
        );
        branch.resize(n, ValueGrad::default());
        for &(k, c) in &self.form.terms {
            if !self.branches[k].value_gradient_batch(&points[..n], branch) {
                return false;
            }
            for (s, b) in sum.iter_mut().zip(branch.iter()) {
                s.value += c * b.value;
                s.gradient += c * b.gradient;
            }
        }
        out[..n].copy_from_slice(sum);
        true
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        bound_on(&self.form, &mut self.branches, lo, hi)
    }

    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        bound_gradient_on(&self.form, &mut self.branches, lo, hi, axes)
    }

    fn fault(&self) -> Option<Fault> {
        self.branches.iter().find_map(|b| b.fault())
    }
}

/// One form of a creased surface as a [`Surface`]: what a smooth piece is marched on.
pub struct Piece<'a> {
    of: &'a mut Creased,
    form: usize,
}

impl Surface for Piece<'_> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.of.form(self.form, p)
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        self.of.form_bound(self.form, lo, hi)
    }

    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        bound_gradient_on(
            &self.of.forms[self.form],
            &mut self.of.branches,
            lo,
            hi,
            axes,
        )
    }

    fn fault(&self) -> Option<Fault> {
        self.of.fault()
    }
}

/// Whether the origin may lie in the convex hull of the plane points `points`: false only
/// when they all lie on one side of a line through the origin, with an angular gap wider
/// than π by a margin (the corners come from outward-rounded intervals; the margin covers
/// the rounding of the angles). A point at the origin or not finite: true.
fn origin_may_be_in_hull(points: &[(f64, f64)]) -> bool {
    let mut angles = Vec::with_capacity(points.len());
    for &(x, y) in points {
        if !(x.is_finite() && y.is_finite()) || (x == 0.0 && y == 0.0) {
            return true;
        }
        angles.push(y.atan2(x));
    }
    angles.sort_by(f64::total_cmp);
    let (Some(&first), Some(&last)) = (angles.first(), angles.last()) else {
        return true;
    };
    let widest = angles
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(first + std::f64::consts::TAU - last, f64::max);
    widest <= std::f64::consts::PI + 1e-9
}

/// f itself through its spine, as a [`Surface`]: its value and partials bounded over a box
/// by the spine pruned over it (the work near a place depends on the forms near it).
pub struct Whole<'a>(pub &'a mut Creased);

impl Surface for Whole<'_> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.0.whole(p)
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        Some(self.0.bound(lo, hi))
    }

    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        self.0.bound_gradient(lo, hi, axes)
    }

    fn gradient_may_face(&mut self, lo: DVec3, hi: DVec3, across: [DVec3; 2]) -> bool {
        self.0.gradient_may_face(lo, hi, across)
    }

    fn fault(&self) -> Option<Fault> {
        self.0.fault()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A form's coefficients over n branches, then its constant.
    fn dense(f: &Form, n: usize) -> Vec<f64> {
        let mut c = vec![0.0; n + 1];
        for &(k, x) in &f.terms {
            c[k] = x;
        }
        c[n] = f.constant;
        c
    }

    /// max(|b0|, b1) − 1: forms b0 − 1, −b0 − 1, b1 − 1.
    fn spine() -> Spine {
        Spine::new(
            vec![
                Term::Branch(0),
                Term::Abs(0),
                Term::Branch(1),
                Term::Max(1, 2),
                Term::Const(1.0),
                Term::Sub(3, 4),
            ],
            2,
        )
        .unwrap()
    }

    #[test]
    fn forms_are_the_patterns_of_choices() {
        let forms = spine().forms(64).unwrap();
        let c: Vec<Vec<f64>> = forms.into_iter().map(|f| dense(&f, 2)).collect();
        assert_eq!(
            c,
            vec![
                vec![1.0, 0.0, -1.0],
                vec![-1.0, 0.0, -1.0],
                vec![0.0, 1.0, -1.0]
            ]
        );
    }

    #[test]
    fn ties_count_both_operands() {
        let s = spine();
        let at = |b0: f64, b1: f64, eps: f64| {
            s.candidates(Some((&[b0, b1], eps)), 64)
                .unwrap()
                .into_iter()
                .map(|c| dense(&c.form, 2))
                .collect::<Vec<_>>()
        };
        assert_eq!(at(2.0, 0.5, 1e-9), vec![vec![1.0, 0.0, -1.0]]);
        assert_eq!(at(-2.0, 0.5, 1e-9), vec![vec![-1.0, 0.0, -1.0]]);
        assert_eq!(at(1.0, 1.0, 1e-9).len(), 2);
        assert_eq!(at(0.0, -1.0, 1e-9).len(), 2);
    }

    #[test]
    fn a_malformed_spine_is_refused() {
        assert_eq!(
            Spine::new(vec![Term::Neg(0)], 0),
            Err(SpineError::Malformed(0))
        );
        assert_eq!(
            Spine::new(vec![Term::Branch(1)], 1),
            Err(SpineError::Malformed(0))
        );
    }

    /// n·p + c, bounded exactly over a box (its partials are n).
    struct Plane(DVec3, f64);

    impl Surface for Plane {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            ValueGrad {
                value: self.0.dot(p) + self.1,
                gradient: self.0,
            }
        }

        fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
            let (mut a, mut b) = (self.1, self.1);
            for k in 0..3 {
                let (x, y) = (self.0[k] * lo[k], self.0[k] * hi[k]);
                (a, b) = (a + x.min(y), b + x.max(y));
            }
            Some(Interval::new(a - 1e-12, b + 1e-12))
        }

        fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, _: [bool; 3]) -> Option<IntervalGrad> {
            let v = self.bound(lo, hi)?;
            Some(IntervalGrad {
                v,
                d: self.0.to_array().map(Interval::point),
                defined: true,
            })
        }
    }

    /// The corner of the box max(x, y, z) − 1 as a spine of three plane branches: along
    /// the crease x = y = 1 the hull of the partials holds 0 (both normals lie on the axes),
    /// so the interval derivatives across any direction may vanish, but no element of the
    /// segment between the normals is parallel to a direction off the axes, and the forms'
    /// hull says so; at the corner, whose normal cone holds the direction, it may.
    #[test]
    fn a_crease_faces_a_direction_only_where_its_normals_span_it() {
        let spine = Spine::new(
            vec![
                Term::Branch(0),
                Term::Branch(1),
                Term::Max(0, 1),
                Term::Branch(2),
                Term::Max(2, 3),
            ],
            3,
        )
        .unwrap();
        let branches: Vec<Box<dyn Surface>> = (0..3)
            .map(|k| Box::new(Plane(DVec3::AXES[k], -1.0)) as Box<dyn Surface>)
            .collect();
        let mut creased = Creased::new(spine, branches).unwrap();
        let d = DVec3::new(0.7, 0.55, 0.45).normalize();
        let (u, w) = d.any_orthonormal_pair();
        let (crease, corner, face) = (
            (DVec3::new(0.99, 0.99, 0.2), DVec3::new(1.01, 1.01, 0.4)),
            (DVec3::splat(0.99), DVec3::splat(1.01)),
            (DVec3::new(0.99, 0.2, 0.3), DVec3::new(1.01, 0.4, 0.5)),
        );
        let hull = creased
            .bound_gradient(crease.0, crease.1, [true; 3])
            .unwrap();
        assert!(hull.derivative_may_vanish(u) && hull.derivative_may_vanish(w));
        assert!(!creased.gradient_may_face(crease.0, crease.1, [u, w]));
        assert!(creased.gradient_may_face(corner.0, corner.1, [u, w]));
        assert!(!creased.gradient_may_face(face.0, face.1, [u, w]));
        // The opposite direction is an extreme too (the smallest d·p): the same answers.
        assert!(creased.gradient_may_face(corner.0, corner.1, [-u, w]));
    }

    /// A plane that answers in batches, or refuses them.
    struct Batched(Plane, bool);

    impl Surface for Batched {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            self.0.value_gradient(p)
        }

        fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
            if self.1 {
                for (o, &p) in out.iter_mut().zip(points) {
                    *o = self.0.value_gradient(p);
                }
            }
            self.1
        }
    }

    /// A detached form's batch is its point-by-point value, bit for bit (the branches summed
    /// in the same order), and nothing is written where a branch refuses batches.
    #[test]
    fn a_detached_batch_is_its_points_bit_for_bit() {
        let mut next = crate::testing::uniform(0x51ed_2701_b4c3_9e11);
        for refuse in [false, true] {
            let branches: Vec<Box<dyn Surface>> = (0..4)
                .map(|k| {
                    let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                    Box::new(Batched(Plane(d, next() - 0.5), !(refuse && k == 2)))
                        as Box<dyn Surface>
                })
                .collect();
            let form = Form {
                terms: vec![(0, 0.3), (2, -1.7), (3, 1e-3)],
                constant: 0.1,
            };
            let mut detached = Detached::new(form, branches).unwrap();
            let points: Vec<DVec3> = (0..37)
                .map(|_| DVec3::new(next(), next(), next()) * 10.0 - 5.0)
                .collect();
            let unset = ValueGrad {
                value: 7.0,
                gradient: DVec3::splat(7.0),
            };
            let mut out = vec![unset; points.len()];
            let batched = detached.value_gradient_batch(&points, &mut out);
            assert_eq!(batched, !refuse);
            for (o, &p) in out.iter().zip(&points) {
                let want = if refuse {
                    unset
                } else {
                    detached.value_gradient(p)
                };
                assert_eq!(o.value.to_bits(), want.value.to_bits());
                assert_eq!(
                    o.gradient.to_array().map(f64::to_bits),
                    want.gradient.to_array().map(f64::to_bits)
                );
            }
        }
    }

    /// A localized spine's pruning from the cells above (`base_for`, `spine_at`) against the
    /// whole spine pruned over the same box, on random CSG trees of planes (min, max, abs,
    /// sums) and boxes of every size: the same terms and the same bound, bit for bit; and
    /// the bound alone (`Creased::bound`) and the pruning where the bound holds 0
    /// (`pruned_if`) are the pruning's.
    #[test]
    fn pruning_from_the_cells_above_is_pruning_the_whole() {
        let mut next = crate::testing::uniform(0x9e37_79b9_7f4a_7c15);
        for _ in 0..40 {
            let n = 3 + (next() * 10.0) as usize;
            let mut terms: Vec<Term> = (0..n).map(Term::Branch).collect();
            // Combine the last term with a random earlier one until one root is left.
            let mut open: Vec<usize> = (0..n).collect();
            while open.len() > 1 {
                let a = open.remove((next() * open.len() as f64) as usize);
                let b = open.remove((next() * open.len() as f64) as usize);
                let (a, b) = (a.min(b), a.max(b));
                let t = match (next() * 5.0) as usize {
                    0 => Term::Min(a, b),
                    1 => Term::Max(a, b),
                    2 => {
                        terms.push(Term::Abs(a));
                        Term::Min(terms.len() - 1, b)
                    }
                    3 => Term::Add(a, b),
                    _ => {
                        terms.push(Term::Neg(b));
                        Term::Max(a, terms.len() - 1)
                    }
                };
                terms.push(t);
                open.push(terms.len() - 1);
            }
            let spine = Spine::new(terms, n).unwrap();
            let branches: Vec<Box<dyn Surface>> = (0..n)
                .map(|_| {
                    let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                    Box::new(Plane(d.normalize(), 0.3 * (next() - 0.5))) as Box<dyn Surface>
                })
                .collect();
            let size = 0.01 + 0.05 * next();
            let mut localized = Creased::new(spine.clone(), branches).unwrap();
            localized.localize(size);
            for _ in 0..200 {
                let c = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let half = size * 40f64.powf(next()) * next();
                let (lo, hi) = (c - DVec3::splat(half), c + DVec3::splat(half));
                let base = localized.base_for(lo, hi);
                let branches = &mut localized.branches;
                let from_cells =
                    base.pruned(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE));
                let whole =
                    spine.pruned(&mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE));
                let bits = |i: Interval| (i.lo.to_bits(), i.hi.to_bits());
                assert_eq!(from_cells.0, whole.0);
                assert_eq!(bits(from_cells.1), bits(whole.1));
                // Pruned only where the bound is wanted, and the bound alone, are the same.
                let near_zero = |b: Interval| b.contains(0.0);
                let kept = spine.pruned_if(
                    &mut |k| branches[k].bound(lo, hi).unwrap_or(Interval::ENTIRE),
                    near_zero,
                );
                assert_eq!(
                    kept.map(|(s, b)| (s, bits(b))),
                    near_zero(whole.1).then(|| (whole.0.clone(), bits(whole.1)))
                );
                assert_eq!(bits(localized.bound(lo, hi)), bits(whole.1));
                // The point query's spine is the whole one pruned over the point's cell.
                let key = (c * size.recip()).floor();
                let cell_lo = key * size - DVec3::splat(0.01 * size);
                let cell_hi = cell_lo + DVec3::splat(1.02 * size);
                let at = localized.spine_at(c);
                let branches = &mut localized.branches;
                let cell = spine.pruned(&mut |k| {
                    branches[k]
                        .bound(cell_lo, cell_hi)
                        .unwrap_or(Interval::ENTIRE)
                });
                assert_eq!(*at, cell.0);
            }
            // Far out, where a cell's key would not be exact, the whole spine.
            let far = DVec3::new(0.3, 1e300, -0.2);
            assert_eq!(*localized.spine_at(far), spine);
            let base = localized.base_for(far, far + DVec3::splat(size * 0.1));
            assert_eq!(*base, spine);
        }
    }

    /// `origin_may_be_in_hull` against a scan of 3 600 directions on random point sets: a
    /// direction with every point clearly on its positive side means false, and a set with a
    /// point clearly on the negative side of every direction means true.
    #[test]
    fn the_origin_in_the_hull_agrees_with_a_scan_of_directions() {
        let mut next = crate::testing::uniform(0x2545_f491_4f6c_dd1d);
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..2000 {
            let n = 1 + (next() * 8.0) as usize;
            let shift = (next() - 0.5, next() - 0.5);
            let points: Vec<(f64, f64)> = (0..n)
                .map(|_| (next() - 0.5 + shift.0, next() - 0.5 + shift.1))
                .collect();
            let side = |k: usize| {
                let a = std::f64::consts::TAU * k as f64 / 3600.0;
                let (c, s) = (a.cos(), a.sin());
                points
                    .iter()
                    .map(|&(x, y)| c * x + s * y)
                    .fold(f64::INFINITY, f64::min)
            };
            let sides: Vec<f64> = (0..3600).map(side).collect();
            let got = origin_may_be_in_hull(&points);
            if sides.iter().any(|&m| m > 1e-3) {
                assert!(!got, "{points:?}");
                outside += 1;
            } else if sides.iter().all(|&m| m < -1e-3) {
                assert!(got, "{points:?}");
                inside += 1;
            }
        }
        assert!(inside > 100 && outside > 100, "{inside} {outside}");
        assert!(origin_may_be_in_hull(&[(1.0, 0.0), (-1.0, 0.0)]));
        assert!(origin_may_be_in_hull(&[(0.0, 0.0)]));
        assert!(origin_may_be_in_hull(&[(f64::NAN, 1.0)]));
    }
}
