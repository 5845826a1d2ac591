//! The dependency graph between definitions: which global names each definition uses, an
//! order in which every definition comes after its dependencies (Kahn's algorithm, smallest
//! index first so the order is deterministic), and the cycles, each found once. Iterative
//! throughout: a file with a hundred thousand chained definitions cannot overflow the stack.

use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

use crate::span::Span;
use crate::syntax::ast;

use super::Checker;

/// The global declarations that declaration `d` uses, with the span of each use.
pub(crate) fn dependencies(c: &Checker<'_>, d: usize) -> Vec<(usize, Span)> {
    let item = c.decls[d].item;
    let mut out = Vec::new();
    let mut visit = |e: &ast::Expr, params: &[&str]| walk(c, e, params, &mut out);
    match &item.kind {
        ast::ItemKind::Const { value, .. } => visit(value, &[]),
        ast::ItemKind::Surface { body, .. } => visit(body, &[]),
        ast::ItemKind::Curve { value, .. } => visit(value, &[]),
        ast::ItemKind::Fn { params, body, .. } => {
            let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
            visit(body, &names);
        }
        ast::ItemKind::Patch { params, body, .. } => {
            for p in params {
                visit(&p.lo, &[]);
                visit(&p.hi, &[]);
            }
            let names: Vec<&str> = params.iter().map(|p| p.name.name.as_str()).collect();
            visit(body, &names);
        }
        ast::ItemKind::Mesh { .. } | ast::ItemKind::Import { .. } => {}
    }
    out
}

fn walk(c: &Checker<'_>, e: &ast::Expr, params: &[&str], out: &mut Vec<(usize, Span)>) {
    let global = |name: &str, span: Span, out: &mut Vec<(usize, Span)>| {
        if !params.contains(&name) {
            if let Some(&d) = c.globals.get(name) {
                out.push((d, span));
            }
        }
    };
    match &e.kind {
        ast::ExprKind::Number { .. } => {}
        ast::ExprKind::Name(n) => global(n, e.span, out),
        ast::ExprKind::Neg(inner) => walk(c, inner, params, out),
        ast::ExprKind::Binary(_, l, r) => {
            walk(c, l, params, out);
            walk(c, r, params, out);
        }
        ast::ExprKind::Call { callee, args } => {
            global(&callee.name, callee.span, out);
            for a in args {
                walk(c, &a.value, params, out);
            }
        }
        ast::ExprKind::Tuple(parts) => {
            for p in parts {
                walk(c, p, params, out);
            }
        }
    }
}

/// A cycle: each node with the span where it uses the next (the last uses the first).
pub(crate) type Cycle = Vec<(usize, Span)>;

/// Returns (processing order of every node, the cycles, the nodes in or behind a cycle).
/// Nodes not behind a cycle come first in dependency order; broken ones follow by index.
pub(crate) fn order(deps: &[Vec<(usize, Span)>]) -> (Vec<usize>, Vec<Cycle>, Vec<usize>) {
    let n = deps.len();
    let mut waiting: Vec<usize> = deps.iter().map(Vec::len).collect();
    let mut dependents: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (d, ds) in deps.iter().enumerate() {
        for &(dep, _) in ds {
            dependents[dep].push(d);
        }
    }
    let mut ready: BinaryHeap<Reverse<usize>> =
        (0..n).filter(|&d| waiting[d] == 0).map(Reverse).collect();
    let mut order = Vec::with_capacity(n);
    let mut done = vec![false; n];
    while let Some(Reverse(d)) = ready.pop() {
        done[d] = true;
        order.push(d);
        for &u in &dependents[d] {
            waiting[u] -= 1;
            if waiting[u] == 0 {
                ready.push(Reverse(u));
            }
        }
    }
    let left: BTreeSet<usize> = (0..n).filter(|&d| !done[d]).collect();
    // Every node left has a dependency left, so walking such dependencies must come back to
    // a node of the walk: that closes a cycle.
    let mut cycles = Vec::new();
    let mut visited = vec![false; n];
    let mut pos_in_path = vec![usize::MAX; n];
    for &start in &left {
        if visited[start] {
            continue;
        }
        let mut path: Vec<(usize, Span)> = Vec::new();
        let mut cur = start;
        loop {
            if visited[cur] {
                if pos_in_path[cur] != usize::MAX
                    && path.get(pos_in_path[cur]).is_some_and(|&(p, _)| p == cur)
                {
                    cycles.push(path[pos_in_path[cur]..].to_vec());
                }
                break;
            }
            visited[cur] = true;
            let Some(&(next, span)) = deps[cur].iter().find(|(dep, _)| left.contains(dep)) else {
                break;
            };
            pos_in_path[cur] = path.len();
            path.push((cur, span));
            cur = next;
        }
    }
    let broken: Vec<usize> = left.iter().copied().collect();
    order.extend(broken.iter().copied());
    (order, cycles, broken)
}
