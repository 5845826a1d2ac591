//! The spine of a surface with creases: f written as `min`, `max`, `abs`, negation, sums and
//! constant factors of smooth *branch* surfaces b₀, b₁, … (each evaluated on its own). Every
//! operation of the spine is linear or picks one operand, so wherever the choices are fixed f
//! is a linear *form* Σ cₖ·bₖ + c: the smooth pieces of f are the zero sets of its forms, and a
//! crease is where two forms are both zero and both chosen (DESIGN.md §4a *Creases*).
//!
//! Built by `compile::spine` from the IR; knows nothing of syntax. Forms are identified by
//! their coefficients, so two patterns of choices that give the same function are one piece.

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
}

/// The spine: terms in topological order, the root last.
#[derive(Clone, Debug, PartialEq)]
pub struct Spine {
    terms: Vec<Term>,
    branches: usize,
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
            };
            if !ok {
                return Err(SpineError::Malformed(i));
            }
        }
        if terms.is_empty() {
            return Err(SpineError::Malformed(0));
        }
        Ok(Spine { terms, branches })
    }

    pub fn branch_count(&self) -> usize {
        self.branches
    }

    /// f from the branch values and gradients (the gradient of the chosen operands).
    pub fn value_gradient(&self, b: &[ValueGrad]) -> ValueGrad {
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
            };
            v.push(x);
        }
        v[v.len() - 1]
    }

    /// Every form of f (every pattern of choices), each once, in a fixed order; at most
    /// `max` of them.
    pub fn forms(&self, max: usize) -> Result<Vec<Form>, SpineError> {
        let cands = self.candidates(None, max)?;
        let mut seen = HashMap::new();
        let mut out = Vec::new();
        for (f, _) in cands {
            if seen.insert(f.key(), out.len()).is_none() {
                out.push(f);
            }
        }
        Ok(out)
    }

    /// The forms f is made of near the point whose branch values are `values`: every pattern
    /// of choices where each choice is the operand taken or within `eps` of it. With `None`,
    /// every pattern. Each form comes with its value.
    fn candidates(
        &self,
        values: Option<(&[f64], f64)>,
        max: usize,
    ) -> Result<Vec<(Form, f64)>, SpineError> {
        let n = self.branches + 1;
        let unit = |k: usize, c: f64| {
            let mut coefficients = vec![0.0; n];
            coefficients[k] = c;
            Form { coefficients }
        };
        let map = |list: &[(Form, f64)], s: f64| -> Vec<(Form, f64)> {
            list.iter()
                .map(|(f, v)| {
                    let coefficients = f.coefficients.iter().map(|c| s * c).collect();
                    (Form { coefficients }, s * v)
                })
                .collect()
        };
        let mut terms: Vec<Vec<(Form, f64)>> = Vec::with_capacity(self.terms.len());
        let value = |list: &[(Form, f64)]| list.first().map_or(f64::NAN, |x| x.1);
        for t in &self.terms {
            let list = match *t {
                Term::Branch(k) => vec![(unit(k, 1.0), values.map_or(0.0, |(b, _)| b[k]))],
                Term::Const(c) => vec![(unit(n - 1, c), c)],
                Term::Neg(a) => map(&terms[a], -1.0),
                Term::Scale(s, a) => map(&terms[a], s),
                Term::Add(a, b) | Term::Sub(a, b) => {
                    let s = if matches!(t, Term::Sub(..)) {
                        -1.0
                    } else {
                        1.0
                    };
                    let mut out = Vec::new();
                    for (fa, va) in &terms[a] {
                        for (fb, vb) in &terms[b] {
                            let coefficients = fa
                                .coefficients
                                .iter()
                                .zip(&fb.coefficients)
                                .map(|(x, y)| x + s * y)
                                .collect();
                            out.push((Form { coefficients }, va + s * vb));
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
}

/// A surface with creases: its spine, the branch surfaces, and the forms (the smooth pieces).
pub struct Creased {
    spine: Spine,
    branches: Vec<Box<dyn Surface>>,
    forms: Vec<Form>,
    index: HashMap<Vec<u64>, usize>,
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
        let forms = spine.forms(MAX_FORMS)?;
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
            .filter_map(|(f, _)| self.index.get(&f.key()).copied())
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
                .map(|(f, _)| f.coefficients)
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
