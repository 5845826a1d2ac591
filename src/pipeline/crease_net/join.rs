//! Joining the pieces of `crease_net`: the pieces' meshes merged at their shared crease
//! vertices, each face's crease polygons chained at the corners into loops, and the checks
//! that the joined mesh is one surface and that every triangle of a crease-free component
//! lies on one face.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

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
        let forward = run.iter().filter(|u| u.forward).count();
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
    merge_at(parts, None).0
}

/// `merge`, where given `only` the positions that may be shared: then only those go into a
/// table (which stays in cache: the slabs of `pipeline::pieces` share only their cut
/// polygons), and each vertex is looked up there rather than hashed into a table of all.
/// Also returns which vertices of the result are among `only` (none without it). Slabs of
/// one smooth surface (`only` given) have no sides: none are recorded.
pub(crate) fn merge_at(parts: &[Mesh], only: Option<&[DVec3]>) -> (Mesh, Vec<bool>) {
    let vertices: usize = parts.iter().map(|p| p.vertices.len()).sum();
    // Each position's id in the merged mesh, once it has one.
    let mut index: HashMap<[u64; 3], Option<u32>, BitsHash> = match only {
        Some(shared) => shared.iter().map(|&p| (bits(p), None)).collect(),
        None => HashMap::with_capacity_and_hasher(vertices, BitsHash),
    };
    let mut out = Mesh {
        vertices: Vec::with_capacity(vertices),
        normals: Vec::with_capacity(vertices),
        triangles: Vec::with_capacity(parts.iter().map(|p| p.triangles.len()).sum()),
        sides: Vec::new(),
    };
    let mut among = Vec::with_capacity(if only.is_some() { vertices } else { 0 });
    let mut met_again = Vec::new();
    // Sides (slabs of one smooth surface, `only` given, have none): the normals met at each
    // vertex met again, where a part's vertex with sides of its own brings those rather than
    // its summed normal; `sided` marks the vertices whose first part brought sides.
    let record_sides = only.is_none();
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
                let slot = match only {
                    Some(_) => index.get_mut(&bits(*v)),
                    None => Some(index.entry(bits(*v)).or_insert(None)),
                };
                if let Some(&mut Some(id)) = slot {
                    if record_sides {
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
                    }
                    out.normals[id as usize] += *n;
                    met_again.push(id);
                    return id;
                }
                if only.is_some() {
                    among.push(slot.is_some());
                }
                if let Some(slot) = slot {
                    *slot = Some(fresh);
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
        if record_sides {
            for side in &part.sides {
                if let Some(&id) = ids.get(side.vertex as usize) {
                    side_normals.entry(id).or_default().push(side.normal);
                }
            }
        }
        out.triangles
            .extend(part.triangles.iter().map(|t| t.map(|k| ids[k as usize])));
    }
    met_again.sort_unstable();
    met_again.dedup();
    for id in met_again {
        let n = &mut out.normals[id as usize];
        *n = n.normalize_or(*n);
    }
    out.sides = sides(side_normals);
    (out, among)
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
