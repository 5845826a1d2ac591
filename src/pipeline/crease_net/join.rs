//! Joining the pieces of `crease_net`: the pieces' meshes merged at their shared crease
//! vertices, each face's crease polygons chained at the corners into loops, and the checks
//! that the joined mesh is one surface and that every triangle of a crease-free component
//! lies on one face.

use std::collections::{HashMap, HashSet};

use glam::DVec3;
use rayon::prelude::*;

use super::CreaseError;
use crate::mesh::Mesh;
use crate::mesh::bits::BitsHash;
use crate::mesh::edges::Edges;
use crate::survey::spine::Creased;

/// The joined mesh is one surface: no edge in more than two triangles, none walked the same
/// way twice (two pieces on one side of a crease), every triangle facing where the normals
/// of its vertices point (a sliver closed across a thin piece does not), and no triangles
/// crossing (each march checks its own; this checks them across pieces and components:
/// `groups`, one a triangle, as `mesh::check::intersecting_pairs_across` takes them).
pub(super) fn check_joined(mesh: &Mesh, groups: &[u32]) -> Result<(), CreaseError> {
    let centre = |t: usize| {
        mesh.triangles[t]
            .iter()
            .map(|&k| mesh.vertices[k as usize])
            .sum::<DVec3>()
            / 3.0
    };
    // The edges' uses, for the edge flaws and for the crossing check's certificate alike;
    // where an edge is run twice one way or a triangle faces against the normals, the
    // first triangle in order that shows it is looked for (`first_flaw`).
    let edges = Edges::new(mesh.vertices.len(), &mesh.triangles);
    let twice = edges.runs().any(|(_, _, run)| {
        let forward = run.iter().filter(|u| u.forward()).count();
        forward > 1 || run.len() - forward > 1
    });
    let flawed = twice || (0..mesh.triangles.len()).any(|n| !faces_its_normals(mesh, n));
    if flawed && let Some((n, why)) = first_flaw(mesh) {
        return Err(CreaseError::Joined { at: centre(n), why });
    }
    if let Some([a, _]) =
        crate::mesh::check::intersecting_pairs_with_edges(mesh, Some(groups), &edges).first()
    {
        return Err(CreaseError::Joined {
            at: centre(*a as usize),
            why: "triangles of two pieces cross",
        });
    }
    Ok(())
}

/// Whether triangle n turns towards the normals of its corners.
fn faces_its_normals(mesh: &Mesh, n: usize) -> bool {
    let t = mesh.triangles[n];
    let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
    let normals: DVec3 = t.iter().map(|&k| mesh.normals[k as usize]).sum();
    let facing = (b - a).cross(c - a).dot(normals);
    !facing.is_nan() && facing > 0.0
}

/// The first triangle, in order, that faces against its corners' normals or runs an edge
/// that triangles before it (or it) run the same way already, and why.
fn first_flaw(mesh: &Mesh) -> Option<(usize, &'static str)> {
    // Each edge's uses each way, keyed by (lower, higher) vertex as one word.
    let mut uses: HashMap<u64, (u32, u32), BitsHash> =
        HashMap::with_capacity_and_hasher(mesh.triangles.len() * 3 / 2 + 16, BitsHash);
    for (n, t) in mesh.triangles.iter().enumerate() {
        if !faces_its_normals(mesh, n) {
            return Some((n, "a triangle faces against the surface's normal"));
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            let entry = uses.entry(key).or_insert((0, 0));
            if a < b {
                entry.0 += 1;
            } else {
                entry.1 += 1;
            }
            if entry.0 > 1 || entry.1 > 1 {
                let why = if entry.0 + entry.1 > 2 {
                    "an edge is in more than two triangles"
                } else {
                    "two triangles on one side of an edge"
                };
                return Some((n, why));
            }
        }
    }
    None
}

/// The meshes as one, vertices with bit-identical positions merged (the crease vertices the
/// pieces share), in order of first appearance.
/// A vertex shared by pieces gets the normalised sum of their normals, which agrees with
/// every triangle around it wherever the crease is not a fold (normals less than 180° apart),
/// and, where the pieces' normals there differ, each of them as a side (`Mesh::sides`, the
/// parts' own sides carried along), so that writers can keep the edge sharp.
pub(crate) fn merge(parts: &[Mesh]) -> Mesh {
    let vertices: usize = parts.iter().map(|p| p.vertices.len()).sum();
    // Each position's id in the merged mesh.
    let mut index: HashMap<[u64; 3], u32, BitsHash> =
        HashMap::with_capacity_and_hasher(vertices, BitsHash);
    let mut out = Mesh {
        vertices: Vec::with_capacity(vertices),
        normals: Vec::with_capacity(vertices),
        triangles: Vec::with_capacity(parts.iter().map(|p| p.triangles.len()).sum()),
        sides: Vec::new(),
    };
    let mut met_again = Vec::new();
    // Sides: the normals met at each vertex met again, where a part's vertex with sides of
    // its own brings those rather than its summed normal; `sided` marks the vertices whose
    // first part brought sides.
    let mut side_normals: HashMap<u32, Vec<DVec3>> = HashMap::new();
    let mut sided: HashSet<u32> = HashSet::new();
    for part in parts {
        let part_sided: HashSet<u32> = part.sides.iter().map(|s| s.vertex).collect();
        let ids: Vec<u32> = part
            .vertices
            .iter()
            .zip(&part.normals)
            .enumerate()
            .map(|(k, (v, n))| {
                let fresh = out.vertices.len() as u32;
                let has_sides = !part_sided.is_empty() && part_sided.contains(&(k as u32));
                let id = *index.entry(bits(*v)).or_insert(fresh);
                if id != fresh {
                    // When the vertex is first met again, the first normal met there is
                    // still the sum's only term.
                    let first = out.normals[id as usize];
                    let met = side_normals.entry(id).or_insert_with(|| {
                        if sided.contains(&id) {
                            Vec::new()
                        } else {
                            vec![first]
                        }
                    });
                    if !has_sides {
                        met.push(*n);
                    }
                    out.normals[id as usize] += *n;
                    met_again.push(id);
                    return id;
                }
                if has_sides {
                    sided.insert(fresh);
                }
                out.vertices.push(*v);
                // Summed from zero (a −0 component becomes +0).
                out.normals.push(DVec3::ZERO + *n);
                fresh
            })
            .collect();
        for side in &part.sides {
            if let Some(&id) = ids.get(side.vertex as usize) {
                side_normals.entry(id).or_default().push(side.normal);
            }
        }
        out.triangles
            .extend(part.triangles.iter().map(|t| t.map(|k| ids[k as usize])));
    }
    normalise_met_again(&mut out.normals, met_again);
    out.sides = sides(side_normals);
    out
}

/// `merge` of slabs of one smooth surface (no sides), where only the positions `shared` may
/// be shared (the slabs of `pipeline::pieces` share only their cut polygons): each vertex
/// is looked up in a table of those alone, which stays in cache. Also returns which
/// vertices of the result are among `shared`. The same mesh as `merge`, bit for bit, with
/// the lookups and the copies on the pool, in three passes: each vertex's place in
/// `shared` (in parallel, a part at a time); the ids in order, as `merge` gives them (a
/// shared position takes the id of its first appearance, every other vertex a fresh one, so
/// each part's fresh vertices are one run of ids); the vertices, normals, marks and
/// triangles copied into each part's runs (in parallel). The normals of the vertices met
/// again are then summed in the order they were met.
pub(crate) fn merge_at(parts: &[Mesh], shared: &[DVec3]) -> (Mesh, Vec<bool>) {
    const NONE: u32 = u32::MAX;
    let mut slots: HashMap<[u64; 3], u32, BitsHash> = HashMap::default();
    for &p in shared {
        let next = slots.len() as u32;
        slots.entry(bits(p)).or_insert(next);
    }
    let hits: Vec<Vec<u32>> = parts
        .par_iter()
        .map(|part| {
            (part.vertices.iter())
                .map(|v| slots.get(&bits(*v)).copied().unwrap_or(NONE))
                .collect()
        })
        .collect();
    // Ids in the order the sequential merge gives them; the normals met again, in order.
    let mut first = vec![NONE; slots.len()];
    let mut fresh = 0u32;
    let mut again: Vec<(u32, DVec3)> = Vec::new();
    let mut starts = Vec::with_capacity(parts.len());
    let ids: Vec<Vec<u32>> = (parts.iter().zip(&hits))
        .map(|(part, hits)| {
            starts.push(fresh);
            (hits.iter().zip(&part.normals))
                .map(|(&slot, &n)| match first.get(slot as usize) {
                    Some(&id) if id != NONE => {
                        again.push((id, n));
                        id
                    }
                    _ => {
                        if let Some(f) = first.get_mut(slot as usize) {
                            *f = fresh;
                        }
                        fresh += 1;
                        fresh - 1
                    }
                })
                .collect()
        })
        .collect();
    let total = fresh as usize;
    let mut out = Mesh {
        vertices: vec![DVec3::ZERO; total],
        normals: vec![DVec3::ZERO; total],
        triangles: vec![[0; 3]; parts.iter().map(|p| p.triangles.len()).sum()],
        sides: Vec::new(),
    };
    let mut among = vec![false; total];
    // Each part's runs of the output, split off in part order.
    let mut runs = Vec::with_capacity(parts.len());
    let (mut vs, mut ns, mut ams, mut ts) = (
        &mut out.vertices[..],
        &mut out.normals[..],
        &mut among[..],
        &mut out.triangles[..],
    );
    for (k, part) in parts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(fresh);
        let count = (end - starts[k]) as usize;
        let (v, v_rest) = std::mem::take(&mut vs).split_at_mut(count);
        let (n, n_rest) = std::mem::take(&mut ns).split_at_mut(count);
        let (a, a_rest) = std::mem::take(&mut ams).split_at_mut(count);
        let (t, t_rest) = std::mem::take(&mut ts).split_at_mut(part.triangles.len());
        (vs, ns, ams, ts) = (v_rest, n_rest, a_rest, t_rest);
        runs.push((v, n, a, t));
    }
    runs.into_par_iter()
        .enumerate()
        .for_each(|(k, (vs, ns, ams, ts))| {
            let (part, ids, hits, start) = (&parts[k], &ids[k], &hits[k], starts[k]);
            for (i, &id) in ids.iter().enumerate() {
                if id >= start {
                    let at = (id - start) as usize;
                    vs[at] = part.vertices[i];
                    // Summed from zero (a −0 component becomes +0), as `merge` does.
                    ns[at] = DVec3::ZERO + part.normals[i];
                    ams[at] = hits[i] != NONE;
                }
            }
            for (t, tri) in ts.iter_mut().zip(&part.triangles) {
                *t = tri.map(|k| ids[k as usize]);
            }
        });
    let mut met_again = Vec::with_capacity(again.len());
    for (id, n) in again {
        out.normals[id as usize] += n;
        met_again.push(id);
    }
    normalise_met_again(&mut out.normals, met_again);
    (out, among)
}

/// The summed normals of the vertices met again (`met_again`, in any order, repeats
/// allowed), each made a unit vector (a zero sum kept as it is).
fn normalise_met_again(normals: &mut [DVec3], mut met_again: Vec<u32>) {
    met_again.sort_unstable();
    met_again.dedup();
    for id in met_again {
        let n = &mut normals[id as usize];
        *n = n.normalize_or(*n);
    }
}

/// The sides of the vertices where different normals met, sorted by vertex, each normal
/// once (compared by value: −0 and +0 are one), in the order they were met.
fn sides(met: HashMap<u32, Vec<DVec3>>) -> Vec<crate::mesh::Side> {
    let mut sides = Vec::new();
    let mut vertices: Vec<u32> = met.keys().copied().collect();
    vertices.sort_unstable();
    for vertex in vertices {
        let mut distinct: Vec<DVec3> = Vec::new();
        for &n in &met[&vertex] {
            if !distinct.contains(&n) {
                distinct.push(n);
            }
        }
        if distinct.len() > 1 {
            sides.extend(
                distinct
                    .into_iter()
                    .map(|normal| crate::mesh::Side { vertex, normal }),
            );
        }
    }
    sides
}

/// A position's bits: the key of a vertex shared bit for bit.
pub(super) fn bits(p: DVec3) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// Joins one face's directed polygons into closed loops at their corners (the last vertex of
/// each loop not repeated). `corners` are the corners' places and, for a tangent crossing,
/// the common normal. A face lies between two of the creases that leave each of its corners,
/// so each corner has one polygon of the face arriving and one leaving — but a tangent
/// crossing, where the face lies in two opposite sectors and has two of each: there the
/// polygon that goes on is the one the face's sector turns to (clockwise about the normal
/// from the arriving one, the face lying on the left of both).
pub(super) fn chain(
    polys: Vec<Side>,
    corners: &[(DVec3, Option<DVec3>)],
) -> Result<Vec<Vec<DVec3>>, CreaseError> {
    let mut loops = Vec::new();
    let mut open: Vec<(Vec<DVec3>, usize, usize)> = Vec::new();
    for (p, ends) in polys {
        match ends {
            None => loops.push(p),
            Some((a, b)) => open.push((p, a, b)),
        }
    }
    let mut used = vec![false; open.len()];
    for first in 0..open.len() {
        if used[first] {
            continue;
        }
        used[first] = true;
        let start = open[first].1;
        let mut ring: Vec<DVec3> = open[first].0.clone();
        let mut end = open[first].2;
        loop {
            let (at, normal) = corners[end];
            let mut next: Vec<usize> = (0..open.len())
                .filter(|&k| !used[k] && open[k].1 == end)
                .collect();
            if end == start {
                // Closed, unless the face passes this tangent crossing twice and its sector
                // here turns to another polygon.
                if normal.is_none() || next.is_empty() {
                    break;
                }
                next.push(first);
            }
            let k = match (&next[..], normal) {
                (&[k], _) => k,
                (&[], _) => return Err(CreaseError::Chain { at }),
                (_, Some(n)) if ring.len() >= 2 => {
                    let arriving = ring[ring.len() - 2] - at;
                    let turn = |k: usize| {
                        let leaving = open[k].0[1] - at;
                        let ccw = n.dot(arriving.cross(leaving)).atan2(arriving.dot(leaving));
                        ccw.rem_euclid(std::f64::consts::TAU)
                    };
                    next.iter()
                        .copied()
                        .max_by(|&a, &b| turn(a).total_cmp(&turn(b)))
                        .unwrap_or(next[0])
                }
                _ => {
                    return Err(CreaseError::SingularCorner {
                        at,
                        pieces: next.len() + 2,
                    });
                }
            };
            if k == first {
                break;
            }
            used[k] = true;
            ring.extend_from_slice(&open[k].0[1..]);
            end = open[k].2;
        }
        // The start corner closes the loop: not repeated.
        ring.pop();
        if ring.len() < 3 {
            return Err(CreaseError::Chain { at: ring[0] });
        }
        loops.push(ring);
    }
    Ok(loops)
}

/// A crease polygon walked with its piece on the left, and its end corners (None: closed).
pub(super) type Side = (Vec<DVec3>, Option<(usize, usize)>);

/// Every triangle of `mesh` from triangle `first` on lies on one face: its vertices have a
/// chosen face in common (ties within `tie · |∇f|`).
pub(super) fn check_smooth(
    c: &mut Creased,
    mesh: &Mesh,
    first: usize,
    tie: f64,
) -> Result<(), CreaseError> {
    let mut active: HashMap<u32, Vec<usize>> = HashMap::new();
    for t in &mesh.triangles[first..] {
        let mut common: Option<Vec<usize>> = None;
        for &k in t {
            let v = mesh.vertices[k as usize];
            let set = active
                .entry(k)
                .or_insert_with(|| {
                    let g = c.whole(v).gradient.length();
                    let mut faces: Vec<usize> = c
                        .active(v, tie * g.max(f64::MIN_POSITIVE))
                        .into_iter()
                        .map(|k| c.class(k))
                        .collect();
                    faces.sort_unstable();
                    faces.dedup();
                    faces
                })
                .clone();
            common = Some(match common {
                None => set,
                Some(cm) => cm.into_iter().filter(|f| set.contains(f)).collect(),
            });
        }
        if common.is_some_and(|cm| cm.is_empty()) {
            let at = t.iter().map(|&k| mesh.vertices[k as usize]).sum::<DVec3>() / 3.0;
            return Err(CreaseError::MissedCrease { at });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::check::ANY_GROUP;

    /// Two triangles that cross (one in z = 0, one in x = 0.1 through it), each with its own
    /// normals: refused as two pieces or with either one moved since (`ANY_GROUP`), and left
    /// to the pieces' own checks when both are of one piece.
    #[test]
    fn crossings_are_looked_for_across_pieces_and_where_moved() {
        let vertices = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.1, 0.2, -0.5),
            DVec3::new(0.1, 0.2, 0.5),
            DVec3::new(0.1, -0.6, 0.0),
        ];
        let normals = vec![DVec3::Z, DVec3::Z, DVec3::Z, DVec3::X, DVec3::X, DVec3::X];
        let mesh = Mesh {
            vertices,
            normals,
            triangles: vec![[0, 1, 2], [3, 4, 5]],
            sides: Vec::new(),
        };
        let crossed = |groups: &[u32]| match check_joined(&mesh, groups) {
            Err(CreaseError::Joined {
                why: "triangles of two pieces cross",
                ..
            }) => true,
            Err(other) => panic!("{other:?}"),
            Ok(()) => false,
        };
        assert!(crossed(&[0, 1]));
        assert!(crossed(&[0, ANY_GROUP]));
        assert!(crossed(&[ANY_GROUP, 0]));
        assert!(crossed(&[ANY_GROUP, ANY_GROUP]));
        assert!(!crossed(&[0, 0]));
    }
}
