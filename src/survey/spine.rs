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

use std::collections::HashMap;

use glam::DVec3;

use crate::compile::tape::Op;
use crate::eval::Interval;
use crate::eval::interval::interval;
use crate::surface::{Surface, ValueGrad};

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

/// A linear form Σ cₖ·bₖ + c over the branches: dense coefficients, the constant last.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    pub coefficients: Vec<f64>,
}

impl Form {
    fn key(&self) -> Vec<u64> {
        // +0 and −0 are one coefficient.
        self.coefficients
            .iter()
            .map(|c| (c + 0.0).to_bits())
            .collect()
    }

    fn constant(&self) -> f64 {
        *self.coefficients.last().unwrap_or(&0.0)
    }

    /// The form's value and gradient from the branches' values and gradients.
    pub fn combine(&self, branches: &[ValueGrad]) -> ValueGrad {
        let mut out = ValueGrad {
            value: self.constant(),
            gradient: DVec3::ZERO,
        };
        for (c, b) in self.coefficients.iter().zip(branches) {
            if *c != 0.0 {
                out.value += c * b.value;
                out.gradient += *c * b.gradient;
            }
        }
        out
    }

    /// The form's value from the branches' values.
    pub fn value(&self, branches: &[f64]) -> f64 {
        let mut v = self.constant();
        for (c, b) in self.coefficients.iter().zip(branches) {
            if *c != 0.0 {
                v += c * b;
            }
        }
        v
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
        let mut v: Vec<ValueGrad> = Vec::with_capacity(self.terms.len());
        let vg = |value: f64, gradient: DVec3| ValueGrad { value, gradient };
        for t in &self.terms {
            let x = match *t {
                Term::Branch(k) => b[k],
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
        v
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
        let n = self.branches + 1;
        let unit = |k: usize, c: f64, value: f64| {
            let mut coefficients = vec![0.0; n];
            coefficients[k] = c;
            Cand {
                form: Form { coefficients },
                value,
                picks: Vec::new(),
            }
        };
        let map = |list: &[Cand], s: f64| -> Vec<Cand> {
            list.iter()
                .map(|c| Cand {
                    form: Form {
                        coefficients: c.form.coefficients.iter().map(|x| s * x).collect(),
                    },
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
                Term::Branch(k) => vec![unit(k, 1.0, values.map_or(0.0, |(b, _)| b[k]))],
                Term::Const(c) => vec![unit(n - 1, c, c)],
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
                            let coefficients = ca
                                .form
                                .coefficients
                                .iter()
                                .zip(&cb.form.coefficients)
                                .map(|(x, y)| x + s * y)
                                .collect();
                            let mut picks = ca.picks.clone();
                            picks.extend_from_slice(&cb.picks);
                            out.push(Cand {
                                form: Form { coefficients },
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

/// A surface with creases: its spine, the branch surfaces, and the forms (the smooth pieces).
pub struct Creased {
    spine: Spine,
    branches: Vec<Box<dyn Surface>>,
    forms: Vec<Form>,
    index: HashMap<Vec<u64>, usize>,
    /// How each pair of forms is told apart (both orders; absent: `Between::Plain`).
    seams: HashMap<(usize, usize), Between>,
    scratch: Vec<ValueGrad>,
}

/// The most forms (smooth pieces) a creased surface may have: each crease search tries the
/// pairs of forms in a cell, and more pieces than this is a pattern explosion (sums of many
/// `abs`), not a solid.
pub const MAX_FORMS: usize = 64;

impl Creased {
    pub fn new(spine: Spine, branches: Vec<Box<dyn Surface>>) -> Result<Creased, SpineError> {
        if branches.len() != spine.branch_count() {
            return Err(SpineError::Malformed(0));
        }
        let with_picks = spine.forms_with_picks(MAX_FORMS)?;
        let mut seams = HashMap::new();
        if spine.has_selectors() {
            for (i, (_, pi)) in with_picks.iter().enumerate() {
                for (j, (_, pj)) in with_picks.iter().enumerate().skip(i + 1) {
                    let b = spine.between(pi, pj);
                    if b != Between::Plain {
                        seams.insert((i, j), b);
                        seams.insert((j, i), b);
                    }
                }
            }
        }
        let forms: Vec<Form> = with_picks.into_iter().map(|f| f.0).collect();
        let index = forms
            .iter()
            .enumerate()
            .map(|(i, f)| (f.key(), i))
            .collect();
        Ok(Creased {
            spine,
            branches,
            forms,
            index,
            seams,
            scratch: Vec::new(),
        })
    }

    pub fn form_count(&self) -> usize {
        self.forms.len()
    }

    fn eval_branches(&mut self, p: DVec3) {
        self.scratch.clear();
        for b in &mut self.branches {
            self.scratch.push(b.value_gradient(p));
        }
    }

    /// Value and gradient of form i at p.
    pub fn form(&mut self, i: usize, p: DVec3) -> ValueGrad {
        self.eval_branches(p);
        self.forms[i].combine(&self.scratch)
    }

    /// Form i and the function whose zero on it is the seam with form j, at p: form j where
    /// a plain `min`/`max`/`abs` tells them apart (they are equal on the seam), else the
    /// selector of the lifted choice between them (see the module documentation), which
    /// stays transversal where the two forms coincide.
    pub fn seam(&mut self, i: usize, j: usize, p: DVec3) -> (ValueGrad, ValueGrad) {
        self.eval_branches(p);
        let li = self.forms[i].combine(&self.scratch);
        let other = match self.seams.get(&(i, j)) {
            Some(&Between::Select(s)) => self.spine.term_values(&self.scratch)[s],
            _ => self.forms[j].combine(&self.scratch),
        };
        (li, other)
    }

    /// Whether forms i and j can meet along a seam: not when only two lifted choices or more
    /// tell them apart (they meet at corners only).
    pub fn adjacent(&self, i: usize, j: usize) -> bool {
        self.seams.get(&(i, j)) != Some(&Between::Apart)
    }

    /// Value and gradient of f at p, through the spine.
    pub fn whole(&mut self, p: DVec3) -> ValueGrad {
        self.eval_branches(p);
        self.spine.value_gradient(&self.scratch)
    }

    /// The forms chosen at p, with every choice within `eps` (function units) of the one
    /// taken counted as a tie: sorted form indices.
    pub fn active(&mut self, p: DVec3, eps: f64) -> Vec<usize> {
        self.eval_branches(p);
        let values: Vec<f64> = self.scratch.iter().map(|b| b.value).collect();
        let Ok(cands) = self.spine.candidates(Some((&values, eps)), usize::MAX) else {
            return Vec::new();
        };
        let mut out: Vec<usize> = cands
            .iter()
            .filter_map(|c| self.index.get(&c.form.key()).copied())
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// An interval holding form i over the box lo..hi, from the branches' bounds (None when
    /// a branch cannot bound itself).
    pub fn form_bound(&mut self, i: usize, lo: DVec3, hi: DVec3) -> Option<Interval> {
        let coefficients = self.forms[i].coefficients.clone();
        let n = coefficients.len();
        let mut acc = Interval::point(coefficients[n - 1]);
        for (k, c) in coefficients[..n - 1].iter().enumerate() {
            if *c == 0.0 {
                continue;
            }
            let b = self.branches[k].bound(lo, hi)?;
            acc = interval(Op::Add, acc, interval(Op::Mul, b, Interval::point(*c)));
        }
        Some(acc)
    }

    /// Form i as a surface of its own.
    pub fn piece(&mut self, i: usize) -> Piece<'_> {
        Piece { of: self, form: i }
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
}

/// f itself through its spine, as a [`Surface`] (its bound from the forms' hull).
pub struct Whole<'a>(pub &'a mut Creased);

impl Surface for Whole<'_> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.0.whole(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let c: Vec<Vec<f64>> = forms.into_iter().map(|f| f.coefficients).collect();
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
                .map(|c| c.form.coefficients)
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
}
