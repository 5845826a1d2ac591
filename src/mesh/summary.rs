//! What `surfc mesh` tells a person on stderr after meshing: a short table (mesh, triangles,
//! time, topology), and with `--stats` a table of shape statistics (the progress lines while
//! it meshes are `progress`'s). The numbers are computed elsewhere; this module only shows
//! them.

use super::quality::MeshReport;

/// One row of the summary table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshSummary<'a> {
    pub name: &'a str,
    pub triangles: usize,
    /// Connected components of the mesh.
    pub components: usize,
    /// Wall-clock time to make the mesh, in seconds.
    pub seconds: f64,
    /// Closed polygons of edges that belong to one triangle only.
    pub boundary_loops: usize,
    /// Edges that belong to more than two triangles.
    pub non_manifold_edges: usize,
}

/// The summary table, one line per mesh after a header line, columns aligned, ending in a
/// newline. Topology reads `watertight` for a closed manifold mesh, else counts its boundary
/// loops and non-manifold edges.
pub fn format_summary(rows: &[MeshSummary]) -> String {
    let header = ["mesh", "triangles", "components", "time", "topology"].map(String::from);
    let lines: Vec<[String; 5]> = rows
        .iter()
        .map(|r| {
            [
                r.name.to_owned(),
                r.triangles.to_string(),
                r.components.to_string(),
                duration(r.seconds),
                topology(r),
            ]
        })
        .collect();
    // Names and topology to the left, numbers to the right.
    aligned(&header, &lines, &[0, 4])
}

fn duration(seconds: f64) -> String {
    if seconds < 1.0 {
        format!("{:.0} ms", seconds * 1000.0)
    } else {
        format!("{seconds:.2} s")
    }
}

fn topology(r: &MeshSummary) -> String {
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    match (r.boundary_loops, r.non_manifold_edges) {
        (0, 0) => "watertight".to_owned(),
        (loops, 0) => plural(loops, "boundary loop"),
        (loops, bad) => format!(
            "{}, {}",
            plural(loops, "boundary loop"),
            plural(bad, "non-manifold edge")
        ),
    }
}

/// The `--stats` table: one line per mesh after a header line, columns aligned: the
/// percentiles of the triangles' smallest angles, the radius ratios, the edge lengths.
pub fn format_stats(rows: &[(&str, &MeshReport)]) -> String {
    let header = [
        "mesh",
        "min°",
        "p1°",
        "p5°",
        "median°",
        "ratio mean",
        "ratio min",
        "edge min",
        "edge mean",
        "edge max",
    ]
    .map(String::from);
    let lines: Vec<[String; 10]> = rows
        .iter()
        .map(|(name, r)| {
            let s = &r.stats;
            let angle = |x: f64| format!("{x:.1}");
            let number = |x: f64| format!("{x:.4}");
            [
                (*name).to_owned(),
                angle(r.min_angle_deg),
                angle(s.min_angle_p1_deg),
                angle(s.min_angle_p5_deg),
                angle(s.min_angle_median_deg),
                number(s.radius_ratio_mean),
                number(s.radius_ratio_min),
                number(s.edge_min),
                number(s.edge_mean),
                number(s.edge_max),
            ]
        })
        .collect();
    aligned(&header, &lines, &[0])
}

/// Rows of cells as text, columns two spaces apart, each line ending in a newline: the
/// columns listed in `left` aligned to the left (the last one unpadded), the others to the
/// right.
fn aligned<const N: usize>(header: &[String; N], lines: &[[String; N]], left: &[usize]) -> String {
    let mut widths = [0usize; N];
    for line in std::iter::once(header).chain(lines) {
        for (w, cell) in widths.iter_mut().zip(line) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    for line in std::iter::once(header).chain(lines) {
        for (k, cell) in line.iter().enumerate() {
            let pad = " ".repeat(widths[k] - cell.chars().count());
            if k > 0 {
                out.push_str("  ");
            }
            if !left.contains(&k) {
                out.push_str(&pad);
            }
            out.push_str(cell);
            if left.contains(&k) && k + 1 < N {
                out.push_str(&pad);
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_aligns_its_columns() {
        let rows = [
            MeshSummary {
                name: "sphere",
                triangles: 1544,
                components: 1,
                seconds: 0.0123,
                boundary_loops: 0,
                non_manifold_edges: 0,
            },
            MeshSummary {
                name: "sphere_six_holes",
                triangles: 2206,
                components: 1,
                seconds: 1.5,
                boundary_loops: 6,
                non_manifold_edges: 0,
            },
            MeshSummary {
                name: "cap",
                triangles: 12,
                components: 2,
                seconds: 0.0004,
                boundary_loops: 1,
                non_manifold_edges: 2,
            },
        ];
        let expected = "\
mesh              triangles  components    time  topology
sphere                 1544           1   12 ms  watertight
sphere_six_holes       2206           1  1.50 s  6 boundary loops
cap                      12           2    0 ms  1 boundary loop, 2 non-manifold edges
";
        assert_eq!(format_summary(&rows), expected);
    }
}
