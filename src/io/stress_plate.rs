//! A generated particle model of the paper's kind (PAPER.md §9: one sphere per node of a stress
//! simulation): the nodes of a square plate with a round hole in its middle, pulled along x,
//! each with its stress from Kirsch's closed-form solution (an infinite plane-stress plate with a
//! hole, which the plate approximates away from its edges). The stress concentrates to three
//! times the applied one at the hole's top and bottom and falls to zero at its sides: a field
//! with structure at every scale, as real simulation output has.

use super::ply::PointTable;

/// The plate's half width; the hole's radius; the applied stress.
pub const HALF_WIDTH: f64 = 1.0;
pub const HOLE_RADIUS: f64 = 0.25;
pub const APPLIED_STRESS: f64 = 1.0;
/// Layers of nodes through the plate's thickness.
pub const LAYERS: usize = 8;

/// Stresses at `(x, y)` (σxx, σyy, τxy), Kirsch's solution for a hole of radius `a` under
/// uniaxial tension `s` along x.
pub fn kirsch(x: f64, y: f64, a: f64, s: f64) -> [f64; 3] {
    let r2 = x * x + y * y;
    let th = y.atan2(x);
    let (q2, q4) = (a * a / r2, a.powi(4) / (r2 * r2));
    let (c2, s2) = ((2.0 * th).cos(), (2.0 * th).sin());
    let rr = 0.5 * s * (1.0 - q2) + 0.5 * s * (1.0 - 4.0 * q2 + 3.0 * q4) * c2;
    let tt = 0.5 * s * (1.0 + q2) - 0.5 * s * (1.0 + 3.0 * q4) * c2;
    let rt = -0.5 * s * (1.0 + 2.0 * q2 - 3.0 * q4) * s2;
    // Polar to Cartesian.
    let (c, sn) = (th.cos(), th.sin());
    let xx = rr * c * c + tt * sn * sn - 2.0 * rt * sn * c;
    let yy = rr * sn * sn + tt * c * c + 2.0 * rt * sn * c;
    let xy = (rr - tt) * sn * c + rt * (c * c - sn * sn);
    [xx, yy, xy]
}

/// Von Mises stress of a plane-stress state.
pub fn von_mises([xx, yy, xy]: [f64; 3]) -> f64 {
    (xx * xx - xx * yy + yy * yy + 3.0 * xy * xy).sqrt()
}

/// About `nodes` nodes on a regular lattice over the plate, [`LAYERS`] deep, none in the hole,
/// with the fields `von_mises` and `sigma_xx`.
pub fn plate(nodes: usize) -> PointTable {
    let (l, a) = (HALF_WIDTH, HOLE_RADIUS);
    let area = 4.0 * l * l - std::f64::consts::PI * a * a;
    let per_layer = (nodes as f64 / LAYERS as f64).max(1.0);
    let h = (area / per_layer).sqrt();
    let side = (2.0 * l / h).round().max(1.0) as usize;
    let h = 2.0 * l / side as f64;
    let mut out = PointTable {
        positions: Vec::with_capacity(nodes + nodes / 16),
        fields: vec![("von_mises".into(), Vec::new()), ("sigma_xx".into(), Vec::new())],
    };
    for j in 0..=side {
        let y = -l + j as f64 * h;
        for i in 0..=side {
            let x = -l + i as f64 * h;
            if x * x + y * y < a * a {
                continue;
            }
            let s = kirsch(x, y, a, APPLIED_STRESS);
            for k in 0..LAYERS {
                out.positions.push([x as f32, y as f32, (k as f64 * h) as f32]);
                out.fields[0].1.push(von_mises(s) as f32);
                out.fields[1].1.push(s[0] as f32);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kirsch_concentrates_three_times_at_the_hole_and_is_the_applied_stress_far_away() {
        let (a, s) = (HOLE_RADIUS, APPLIED_STRESS);
        // Top of the hole: σxx = 3s; its side: σyy = -s, σxx = 0.
        let top = kirsch(0.0, a, a, s);
        assert!((top[0] - 3.0 * s).abs() < 1e-12 && top[1].abs() < 1e-12, "{top:?}");
        let side = kirsch(a, 0.0, a, s);
        assert!(side[0].abs() < 1e-12 && (side[1] + s).abs() < 1e-12, "{side:?}");
        let far = kirsch(1e4, 3e3, a, s);
        assert!((far[0] - s).abs() < 1e-6 && far[1].abs() < 1e-6 && far[2].abs() < 1e-6, "{far:?}");
        assert!((von_mises(far) - s).abs() < 1e-6);
    }

    #[test]
    fn the_plate_has_about_the_nodes_asked_for_and_none_in_the_hole() {
        let p = plate(100_000);
        let n = p.positions.len();
        assert!((90_000..110_000).contains(&n), "{n}");
        assert!(p
            .positions
            .iter()
            .all(|q| (q[0] * q[0] + q[1] * q[1]) as f64 >= HOLE_RADIUS * HOLE_RADIUS * 0.999));
        assert!(p.fields.iter().all(|(_, v)| v.len() == n));
    }
}
